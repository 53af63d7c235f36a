use super::*;

const MINIMAL: &str = r#"
[gateway]
name = "gw1"
broker = "mqtt://127.0.0.1:1883"

[[bus]]
name = "line1"
protocol = "movilink"
port = "/dev/ttyUSB0"

[[bus.drive]]
name = "conveyor"
address = 1

[[bus.drive.param]]
param = "P130"
period = "1s"
writable = true
"#;

fn err(text: &str) -> String {
    match Plant::parse(text, "plant.toml") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn with(replace: &str, by: &str) -> String {
    assert!(MINIMAL.contains(replace), "{replace}");
    MINIMAL.replace(replace, by)
}

#[test]
fn a_minimal_config_gets_the_documented_defaults() {
    let p = Plant::parse(MINIMAL, "plant.toml").unwrap();
    assert_eq!(p.gateway.prefix, "drivebus");
    assert_eq!(p.gateway.client_id, "drivebus-gw1");
    assert_eq!(p.gateway.heartbeat, Duration::from_secs(60));
    assert_eq!(p.gateway.max_set_age, Duration::from_secs(10));
    assert_eq!(p.gateway.metrics, Some("127.0.0.1:9464".parse().unwrap()));
    let b = &p.buses[0];
    assert_eq!(b.protocol, Protocol::Movilink);
    assert_eq!(b.timeout, Duration::from_millis(100));
    assert_eq!(b.retries, 1);
    assert_eq!(b.status_period, Duration::from_secs(5));
    match &b.endpoint {
        Endpoint::Serial { path, line, .. } => {
            assert_eq!(path, "/dev/ttyUSB0");
            assert_eq!(line.baud, 9600);
            assert_eq!(line.parity, Parity::Even);
        }
        other => panic!("{other:?}"),
    }
    let d = &b.drives[0];
    assert_eq!(d.points[0].target.family, Family::Movidrive);
    let pt = &d.points[0];
    assert_eq!(pt.name, "P130");
    assert_eq!(pt.target.index, 8470, "P130 ramp t11 up CW is index 8470");
    assert_eq!(pt.period, Some(Duration::from_secs(1)));
    assert!(pt.writable && !pt.eeprom);
}

#[test]
fn durations_need_a_unit() {
    assert_eq!(parse_duration("250ms"), Some(Duration::from_millis(250)));
    assert_eq!(parse_duration(" 5s "), Some(Duration::from_secs(5)));
    assert_eq!(parse_duration("1.5s"), Some(Duration::from_millis(1500)));
    assert_eq!(parse_duration("2m"), Some(Duration::from_secs(120)));
    assert_eq!(parse_duration("500us"), Some(Duration::from_micros(500)));
    for bad in ["5", "", "s", "-1s", "1e400s", "5 parsecs", "NaNs", "1.2.3s"] {
        assert_eq!(parse_duration(bad), None, "{bad}");
    }
}

#[test]
fn every_mistake_is_named_with_what_to_write() {
    let cases = [
        (with("name = \"gw1\"", "name = \"gw/1\""), "topic level"),
        (
            with("mqtt://127.0.0.1:1883", "http://x"),
            "mqtt://host:port",
        ),
        (
            with("mqtt://127.0.0.1:1883", "mqtt://u:secret@h:1883"),
            "no password in the URL",
        ),
        (with("mqtt://127.0.0.1:1883", "mqtt://h:99999"), "1–65535"),
        (
            with("protocol = \"movilink\"", "protocol = \"profibus\""),
            "movilink, sbus",
        ),
        (with("address = 1", "address = 100"), "addresses 0–99"),
        (with("period = \"1s\"", "period = \"1\""), "give a duration"),
        (
            with(
                "port = \"/dev/ttyUSB0\"",
                "port = \"/dev/ttyUSB0\"\ntimeout = \"1ms\"",
            ),
            "shorter than the start pause",
        ),
        (
            with(
                "port = \"/dev/ttyUSB0\"",
                "port = \"/dev/ttyUSB0\"\nbaud = 300\ntimeout = \"20ms\"",
            ),
            "at 300 baud",
        ),
        (
            with("port = \"/dev/ttyUSB0\"", "port = \"/dev/ptmx\""),
            "is the pseudo-terminal multiplexer",
        ),
        (
            with(
                "protocol = \"movilink\"\nport = \"/dev/ttyUSB0\"",
                "protocol = \"modbus-rtu\"\nport = \"/dev/ttyUSB0\"\ntimeout = \"5ms\"",
            )
            .replace("P130", "372"),
            "10 ms answer delay",
        ),
        (
            with(
                "protocol = \"movilink\"\nport = \"/dev/ttyUSB0\"",
                "protocol = \"sbus\"\niface = \"can0\"\ntimeout = \"1ms\"",
            ),
            "at 500 kbit/s",
        ),
        (
            with("param = \"P130\"", "param = \"P9999\""),
            "no movidrive parameter",
        ),
        (
            with("writable = true", "writable = false\nperiod2 = 1"),
            "unknown field",
        ),
        (
            with("port = \"/dev/ttyUSB0\"", "iface = \"can0\""),
            "serial port",
        ),
        (
            with(
                "protocol = \"movilink\"\nport = \"/dev/ttyUSB0\"",
                "protocol = \"sbus\"\niface = \"slcan:\"",
            ),
            "iface = \"slcan:\": no serial port after slcan:",
        ),
        (
            with(
                "protocol = \"movilink\"\nport = \"/dev/ttyUSB0\"",
                "protocol = \"sbus\"\niface = \"slcan:/dev/x@300k\"",
            ),
            "iface = \"slcan:/dev/x@300k\": ",
        ),
        (
            with(
                "protocol = \"movilink\"\nport = \"/dev/ttyUSB0\"",
                "protocol = \"sbus\"\niface = \"\"",
            ),
            "iface = \"\": give \"can0\"",
        ),
        (
            with(
                "protocol = \"movilink\"\nport = \"/dev/ttyUSB0\"",
                "protocol = \"sbus\"\niface = \"a/b\"",
            ),
            "iface = \"a/b\": not a SocketCAN interface name",
        ),
        (
            with(
                "[[bus.drive.param]]",
                "[bus.drive.process_data]\nperiod = \"20ms\"\nout = [1,2,3,4]\n[[bus.drive.param]]",
            ),
            "1–3 words",
        ),
    ];
    for (text, needle) in cases {
        let e = err(&text);
        let line = e
            .strip_prefix("plant.toml:")
            .and_then(|r| r.split_once(": "))
            .map(|(l, _)| l.parse::<usize>());
        assert!(matches!(line, Some(Ok(_))), "no line: {e}");
        assert!(e.contains(needle), "`{needle}` not in: {e}");
        assert!(!e.contains("--"), "a command-line option in: {e}");
    }
}

#[test]
fn two_buses_on_one_port_are_refused_also_through_a_symlink() {
    let dir = std::env::temp_dir().join(format!("gwcfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let real = dir.join("ttyREAL");
    std::fs::write(&real, "").unwrap();
    let link = dir.join("ttyLINK");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&real, &link).unwrap();
    let second = MINIMAL
        .split("[[bus]]")
        .nth(1)
        .unwrap()
        .replace("line1", "line2")
        .replace("/dev/ttyUSB0", link.to_str().unwrap());
    let text = format!(
        "{}\n[[bus]]{second}",
        MINIMAL.replace("/dev/ttyUSB0", real.to_str().unwrap())
    );
    let e = err(&text);
    assert!(e.contains("one port, one bus"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_can_bus_has_one_bit_rate() {
    let sbus = |iface: &str, extra: &str| {
        MINIMAL
            .replace("protocol = \"movilink\"", "protocol = \"sbus\"")
            .replace(
                "port = \"/dev/ttyUSB0\"",
                &format!("iface = \"{iface}\"\n{extra}"),
            )
    };
    let rate = |text: String| match Plant::parse(&text, "p").unwrap().buses[0].endpoint.clone() {
        Endpoint::Can { iface, bitrate } => (iface, bitrate),
        other => panic!("{other:?}"),
    };
    assert_eq!(rate(sbus("can0", "")), ("can0".into(), 500_000));
    assert_eq!(
        rate(sbus("can0", "bitrate = \"250k\"")),
        ("can0".into(), 250_000)
    );
    // slcan: the adapter is opened at the config's rate.
    assert_eq!(
        rate(sbus("slcan:/dev/ttyACM0", "bitrate = \"125k\"")),
        ("slcan:/dev/ttyACM0@125000".into(), 125_000)
    );
    assert_eq!(
        rate(sbus("slcan:/dev/ttyACM0@1M", "")),
        ("slcan:/dev/ttyACM0@1M".into(), 1_000_000)
    );
    assert!(
        err(&sbus("slcan:/dev/ttyACM0@1M", "bitrate = \"500k\""))
            .contains("give the bit rate once")
    );
    assert!(err(&sbus("virtual", "")).contains("simulate = true"));
    // Two buses on one slcan adapter, once with its rate.
    let two = format!(
        "{}\n[[bus]]{}",
        sbus("slcan:/dev/ttyACM0", ""),
        sbus("slcan:/dev/ttyACM0@500k", "")
            .split("[[bus]]")
            .nth(1)
            .unwrap()
            .replace("line1", "line2")
    );
    assert!(err(&two).contains("one port, one bus"), "{}", err(&two));
}

#[test]
fn duplicates_are_refused() {
    let two_drives = MINIMAL.replace(
            "[[bus.drive]]",
            "[[bus.drive]]\nname = \"other\"\naddress = 1\n[[bus.drive.param]]\nparam = \"P000\"\nperiod = \"1s\"\n\n[[bus.drive]]",
        );
    assert!(err(&two_drives).contains("two drives at address 1"));
    let two_points = format!("{MINIMAL}\n[[bus.drive.param]]\nparam = \"P130\"\nperiod = \"2s\"\n");
    assert!(err(&two_points).contains("listed twice"));
    let reserved = with("period = \"1s\"", "period = \"1s\"\nname = \"status\"");
    assert!(err(&reserved).contains("not status"));
}

#[test]
fn a_notepad_file_with_bom_and_crlf_loads() {
    let dir = std::env::temp_dir().join(format!("gwcfg-bom-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("plant.toml");
    std::fs::write(&f, format!("\u{feff}{}", MINIMAL.replace('\n', "\r\n"))).unwrap();
    let p = Plant::load(f.to_str().unwrap()).unwrap();
    assert_eq!(p.buses[0].drives[0].points[0].name, "P130");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_device_node_is_not_read_as_a_config() {
    let e = Plant::load("/dev/zero").unwrap_err().to_string();
    assert!(e.contains("device node"), "{e}");
}

#[test]
fn family_specific_keys_follow_the_protocol() {
    let nord = MINIMAL
        .replace("\"movilink\"", "\"uss\"")
        .replace("P130", "P102")
        .replace("writable = true", "writable = true\nset = 2");
    let p = Plant::parse(&nord, "p").unwrap();
    assert_eq!(p.buses[0].drives[0].points[0].target.family, Family::Nord);
    let bonf = MINIMAL
        .replace("\"movilink\"", "\"modbus-rtu\"")
        .replace("P130", "372")
        .replace("writable = true", "writable = true\ndata_set = 7");
    let p = Plant::parse(&bonf, "p").unwrap();
    assert_eq!(p.buses[0].drives[0].points[0].target.sub, 7);
    let wrong = MINIMAL.replace("writable = true", "writable = true\ndata_set = 1");
    assert!(err(&wrong).contains("data_set is for bonfiglioli parameters only"));
    let fam = MINIMAL.replace("address = 1", "address = 1\nfamily = \"nord\"");
    assert!(err(&fam).contains("movilink talks to"));
    // A Bonfiglioli drive's variant, for the meaning of its status word 411.
    let acu = bonf.replace("address = 1", "address = 1\nvariant = \"ACU\"");
    let p = Plant::parse(&acu, "p").unwrap();
    assert_eq!(
        p.buses[0].drives[0].device,
        drive_client::meaning::Device::bonfiglioli(
            drive_profile::bonfiglioli::Variant::Acu,
            "given"
        )
    );
    let bad = bonf.replace("address = 1", "address = 1\nvariant = \"cube\"");
    assert!(
        err(&bad).contains("variant = \"cube\": give \"act\""),
        "{}",
        err(&bad)
    );
    let sew = MINIMAL.replace("address = 1", "address = 1\nvariant = \"act\"");
    assert!(
        err(&sew).contains("variant is a key of Bonfiglioli drives"),
        "{}",
        err(&sew)
    );
}

#[test]
fn issue18_a_default_timeout_no_answer_can_meet_is_raised_to_the_floor() {
    let slow = MINIMAL
        .replace("\"movilink\"", "\"modbus-rtu\"")
        .replace(
            "port = \"/dev/ttyUSB0\"",
            "port = \"/dev/ttyUSB0\"\nbaud = 1200",
        )
        .replace("P130", "372");
    let p = Plant::parse(&slow, "p").unwrap();
    let Endpoint::Serial { line, .. } = &p.buses[0].endpoint else {
        panic!("{:?}", p.buses[0].endpoint);
    };
    assert_eq!(line.baud, 1200);
    let least = bonfiglioli_modbus::master::least_response_timeout(
        bonfiglioli_modbus::framing::Mode::Rtu,
        line,
    );
    assert!(least > Duration::from_millis(100), "{least:?}");
    assert!(p.buses[0].timeout >= least, "{:?}", p.buses[0].timeout);
    // At 9600 baud the protocol's default stands.
    let fast = slow.replace("baud = 1200", "baud = 9600");
    assert_eq!(
        Plant::parse(&fast, "p").unwrap().buses[0].timeout,
        Duration::from_millis(100)
    );
}

/// A config of one drive `d` on bus `b` of `protocol` with one point `pt` of `lines`.
fn one_point(protocol: &str, lines: &str) -> String {
    format!(
        "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h\"\n\n[[bus]]\nname = \"b\"\n\
             protocol = \"{protocol}\"\nsimulate = true\n\n[[bus.drive]]\nname = \"d\"\n\
             address = 1\n\n[[bus.drive.param]]\nname = \"pt\"\nperiod = \"1s\"\n{lines}\n"
    )
}

/// Issue 18 A2: every parameter set, array element and data set the table does not give
/// the parameter, a write to a parameter the gateway must not write, and a Modbus
/// parameter without a data type and without `width` are refused at load, with the key
/// and its line, never a command-line option.
#[test]
fn issue18_selectors_the_table_does_not_have_are_refused() {
    // (protocol, the point's lines, the key whose line is named, what the message says)
    let cases: &[(&str, &str, &str, &str)] = &[
        // NORD parameter sets: 1–4 where the parameter has sets, none where it has none.
        (
            "uss",
            "param = \"P102\"\nset = 0",
            "set = 0",
            "P102 acceleration time has parameter sets 1–4",
        ),
        (
            "uss",
            "param = \"P102\"\nset = 5",
            "set = 5",
            "has parameter sets 1–4",
        ),
        (
            "uss",
            "param = \"P102\"\nset = 7",
            "set = 7",
            "has parameter sets 1–4",
        ),
        (
            "uss",
            "param = \"P102\"\nset = 99",
            "set = 99",
            "has parameter sets 1–4",
        ),
        (
            "uss",
            "param = \"P560\"\nset = 1",
            "set = 1",
            "P560 save to EEPROM has no parameter sets",
        ),
        (
            "uss",
            "param = \"P543\"\narray = 1\nset = 2",
            "set = 2",
            "has no parameter sets",
        ),
        // NORD array elements: 1…length of an array, none for a parameter that is none.
        (
            "uss",
            "param = \"P543\"\narray = 0",
            "array = 0",
            "P543 bus actual value has the elements 1…3 ([-01]…[-03])",
        ),
        (
            "uss",
            "param = \"P543\"\narray = 4",
            "array = 4",
            "has the elements 1…3",
        ),
        (
            "uss",
            "param = \"P700\"\narray = 200",
            "array = 200",
            "has the elements 1…3",
        ),
        (
            "uss",
            "param = \"P543\"",
            "param = ",
            "is an array of 3 elements ([-01]…[-03]): give array = 1…3",
        ),
        (
            "uss",
            "param = \"P102\"\narray = 1",
            "array = 1",
            "P102 acceleration time is no array",
        ),
        // Outside the table: what the IND word can carry.
        (
            "uss",
            "param = \"2000\"\nset = 0",
            "set = 0",
            "parameter sets 1–4",
        ),
        (
            "uss",
            "param = \"2000\"\nset = 5",
            "set = 5",
            "parameter sets 1–4",
        ),
        (
            "uss",
            "param = \"2000\"\narray = 0",
            "array = 0",
            "count from 1",
        ),
        (
            "uss",
            "param = \"2000\"\nset = 1\narray = 65",
            "array = 65",
            "elements 1…64",
        ),
        // Bonfiglioli data sets: 0–9 for data-set parameters, 0 or 5 for the others.
        (
            "modbus-rtu",
            "param = \"260\"\ndata_set = 1",
            "data_set = 1",
            "260 Current fault has no data sets: give 0 (or 5, its RAM image)",
        ),
        (
            "modbus-rtu",
            "param = \"260\"\ndata_set = 9",
            "data_set = 9",
            "has no data sets",
        ),
        (
            "modbus-ascii",
            "param = \"372\"\ndata_set = 10",
            "data_set = 10",
            "give 0–9",
        ),
        (
            "modbus-rtu",
            "param = \"372\"\ndata_set = 6\neeprom = true\nwritable = true",
            "eeprom = true",
            "data_set = 6 is the RAM image of data set 1",
        ),
        // Bonfiglioli widths: the manual's data type, else width = 16 | 32.
        (
            "modbus-rtu",
            "param = \"415\"",
            "param = ",
            "the manual gives no data type for 415 IDC compensation limit: give width = 16 (FC 3/6) or width = 32",
        ),
        (
            "modbus-rtu",
            "param = \"1000\"",
            "param = ",
            "the manual gives no data type for index 1000",
        ),
        (
            "modbus-rtu",
            "param = \"415\"\nwidth = 8",
            "width = 8",
            "give 16 (FC 3/6) or 32",
        ),
        (
            "modbus-rtu",
            "param = \"481\"\nwidth = 16",
            "width = 16",
            "the manual gives 481 Fixed frequency 2 32 bits",
        ),
        // A parameter the family does not have, in the config's terms.
        (
            "uss",
            "param = \"P9999\"",
            "param = ",
            "param = \"P9999\": no nord parameter of that name or number",
        ),
        (
            "modbus-rtu",
            "param = \"P9999\"",
            "param = ",
            "no bonfiglioli parameter",
        ),
        (
            "movilink",
            "param = \"P9999\"",
            "param = ",
            "no movidrive parameter",
        ),
        // Keys of another family.
        (
            "movilink",
            "param = \"P130\"\nset = 1",
            "set = 1",
            "set is for nord parameters only (uss buses)",
        ),
        (
            "sbus",
            "param = \"P130\"\narray = 1",
            "array = 1",
            "array is for nord parameters only",
        ),
        (
            "uss",
            "param = \"P102\"\ndata_set = 1",
            "data_set = 1",
            "data_set is for bonfiglioli parameters only",
        ),
        (
            "uss",
            "param = \"P102\"\nwidth = 16",
            "width = 16",
            "width is for bonfiglioli parameters only",
        ),
        (
            "modbus-rtu",
            "param = \"481\"\nset = 1",
            "set = 1",
            "set is for nord parameters only",
        ),
        (
            "movilink",
            "param = \"P130\"\ndata_set = 0",
            "data_set = 0",
            "data_set is for bonfiglioli",
        ),
        // Writes the gateway never makes: read-only, outside the table, the link's own.
        (
            "uss",
            "param = \"P700\"\narray = 1\nwritable = true",
            "writable = true",
            "P700 present fault is read-only",
        ),
        (
            "modbus-rtu",
            "param = \"210\"\nwritable = true",
            "writable = true",
            "210 Stator frequency is read-only",
        ),
        (
            "modbus-rtu",
            "param = \"260\"\nwritable = true",
            "writable = true",
            "is read-only",
        ),
        (
            "movilink",
            "param = \"P000\"\nwritable = true",
            "writable = true",
            "is read-only",
        ),
        (
            "sbus",
            "param = \"P004\"\nwritable = true",
            "writable = true",
            "is read-only",
        ),
        (
            "uss",
            "param = \"2000\"\nwritable = true",
            "writable = true",
            "is not in the nord parameter table",
        ),
        (
            "movilink",
            "param = \"9999\"\nwritable = true",
            "writable = true",
            "is not in the movidrive parameter table",
        ),
        (
            "modbus-rtu",
            "param = \"1000\"\nwidth = 16\nwritable = true",
            "writable = true",
            "is not in the bonfiglioli parameter table",
        ),
        (
            "movilink",
            "param = \"P810\"\nwritable = true",
            "writable = true",
            "a setting of the link the gateway talks over",
        ),
        (
            "sbus",
            "param = \"P815\"\nwritable = true",
            "writable = true",
            "a setting of the link",
        ),
        (
            "modbus-rtu",
            "param = \"10\"\nwidth = 16\nwritable = true",
            "writable = true",
            "a setting of the link",
        ),
    ];
    for (protocol, lines, key, needle) in cases {
        let text = one_point(protocol, lines);
        let line = text
            .lines()
            .position(|l| l.starts_with(key))
            .map(|i| i + 1)
            .unwrap();
        let e = err(&text);
        let at = format!("plant.toml:{line}: bus \"b\" drive \"d\" point \"pt\": ");
        assert!(e.starts_with(&at), "{protocol} {lines:?}: not at {at}: {e}");
        assert!(
            e.contains(needle),
            "{protocol} {lines:?}: `{needle}` not in: {e}"
        );
        assert!(!e.contains("--"), "a command-line option in: {e}");
    }
}

/// The selectors the table has are taken, and address what they say.
#[test]
fn issue18_the_selectors_the_table_has_are_taken() {
    use bonfiglioli_modbus::slave::Width;
    use drive_client::target::nord_sub;
    let point = |protocol: &str, lines: &str| {
        Plant::parse(&one_point(protocol, lines), "plant.toml")
            .unwrap_or_else(|e| panic!("{protocol} {lines:?}: {e}"))
            .buses
            .remove(0)
            .drives
            .remove(0)
            .points
            .remove(0)
    };
    let p102 = drive_profile::nord::by_number(102).unwrap().pnu;
    for set in 1..=4 {
        let p = point(
            "uss",
            &format!("param = \"P102\"\nset = {set}\nwritable = true"),
        );
        assert_eq!(p.target.sub, nord_sub(p102, None, Some(set)), "set {set}");
        assert_eq!(p.target.label(), format!("P102 set {set}"));
    }
    // Without `set`: set 1.
    assert_eq!(
        point("uss", "param = \"P102\"").target.label(),
        "P102 set 1"
    );
    for k in 1..=3 {
        let p = point("uss", &format!("param = \"P543\"\narray = {k}"));
        assert_eq!(p.target.label(), format!("P543 [-{k:02}]"));
    }
    for ds in 0..=9u8 {
        let p = point("modbus-rtu", &format!("param = \"372\"\ndata_set = {ds}"));
        assert_eq!(p.target.sub, u16::from(ds));
    }
    for ds in [0u8, 5] {
        assert_eq!(
            point("modbus-rtu", &format!("param = \"260\"\ndata_set = {ds}"))
                .target
                .sub,
            u16::from(ds)
        );
    }
    // The table's width is used as it is; an untyped parameter takes the config's.
    assert_eq!(
        point("modbus-rtu", "param = \"481\"\nwidth = 32").width,
        None
    );
    assert_eq!(
        point("modbus-rtu", "param = \"415\"\nwidth = 16\nwritable = true").width,
        Some(Width::Word)
    );
    assert_eq!(
        point("modbus-ascii", "param = \"1000\"\nwidth = 32").width,
        Some(Width::Long)
    );
    assert!(
        point(
            "modbus-rtu",
            "param = \"481\"\ndata_set = 5\nwritable = true"
        )
        .writable
    );
}

/// `page_control` lets the page drive a drive over its process data; it is off unless given,
/// and only a boolean.
#[test]
fn page_control_is_a_boolean_of_the_process_data_and_off_by_default() {
    let pd = |extra: &str| {
        with(
            "[[bus.drive.param]]",
            &format!(
                "[bus.drive.process_data]\nperiod = \"50ms\"\nout = [2, 0]\n{extra}[[bus.drive.param]]"
            ),
        )
    };
    let drive = |text: &str| {
        let plant = Plant::parse(text, "plant.toml").unwrap();
        plant.buses[0].drives[0].process_data.clone().unwrap()
    };
    assert!(!drive(&pd("")).page_control);
    assert!(drive(&pd("page_control = true\n")).page_control);
    let e = err(&pd("page_control = \"yes\"\n"));
    assert!(
        e.contains("expected a boolean") && e.starts_with("plant.toml:18:"),
        "{e}"
    );
}

#[test]
fn a_serial_bus_takes_its_adapters_echo_and_rs485_mode() {
    let port = "port = \"/dev/ttyUSB0\"";
    let p = Plant::parse(
        &with(
            port,
            "port = \"/dev/ttyUSB0\"\necho = true\nrs485 = true\nrs485_rts = \"low\"\n\
             rs485_delay_before = \"2ms\"\nrs485_delay_after = \"1ms\"",
        ),
        "plant.toml",
    )
    .unwrap();
    let Endpoint::Serial { adapter, .. } = &p.buses[0].endpoint else {
        panic!("{:?}", p.buses[0].endpoint);
    };
    assert!(adapter.echo);
    let rs485 = adapter.rs485.unwrap();
    assert!(!rs485.rts_on_send && rs485.rts_after_send);
    assert_eq!(
        (
            rs485.delay_rts_before_send_ms,
            rs485.delay_rts_after_send_ms
        ),
        (2, 1)
    );
    // By default: no echo, the port's RS-485 setting left as it is.
    let p = Plant::parse(MINIMAL, "plant.toml").unwrap();
    let Endpoint::Serial { adapter, .. } = &p.buses[0].endpoint else {
        panic!();
    };
    assert_eq!(*adapter, Adapter::default());
    for (keys, says) in [
        ("rs485_rts = \"low\"", "add rs485 = true"),
        ("rs485 = true\nrs485_rts = \"up\"", "give \"high\""),
        (
            "rs485 = true\nrs485_delay_before = \"200ms\"",
            "0ms to 100ms",
        ),
        (
            "rs485 = true\nrs485_delay_after = \"500us\"",
            "whole milliseconds",
        ),
        ("rs485 = true\nrs485_delay_after = \"2\"", "give a duration"),
    ] {
        let e = err(&with(port, &format!("{port}\n{keys}")));
        assert!(e.contains(says), "{keys}: {e}");
    }
    let sbus = with("protocol = \"movilink\"", "protocol = \"sbus\"")
        .replace(port, "iface = \"can0\"\necho = true");
    assert!(err(&sbus).contains("serial adapter"), "{}", err(&sbus));
}
