//! The page's hub, its routes and its refusals, over a real loopback socket.

use std::time::{Duration, SystemTime};

use tokio::io::{AsyncReadExt, AsyncWriteExt};

use super::*;
use crate::model::DriveStatus;

fn plant(extra: &str) -> Arc<Plant> {
    let text = format!(
        "[gateway]\nname = \"gw\"\nbroker = \"off\"\n\
         [[bus]]\nname = \"b\"\nprotocol = \"movilink\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"d\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\nwritable = true\n\
         [[bus.drive.param]]\nparam = \"P700\"\nperiod = \"1s\"\n\
         [ui]\nlisten = \"127.0.0.1:0\"\n{extra}"
    );
    Arc::new(Plant::parse(&text, "test").unwrap())
}

fn value(point: usize, raw: i64) -> Update {
    Update::Value {
        bus: 0,
        drive: 0,
        point,
        raw,
        at: SystemTime::UNIX_EPOCH + Duration::from_millis(1_000),
    }
}

#[test]
fn the_page_is_served_on_loopback_only_and_needs_a_broker_or_itself() {
    assert_eq!(
        check_ui_of("127.0.0.1:8080").unwrap().listen,
        "127.0.0.1:8080".parse().unwrap()
    );
    assert!(check_ui_of("[::1]:8080").is_ok());
    for other in ["0.0.0.0:8080", "192.168.1.20:80", "[::]:8080"] {
        let e = check_ui_of(other).unwrap_err();
        assert!(
            e.contains("loopback") && e.contains("TLS and users"),
            "{other}: {e}"
        );
    }
    assert!(check_ui_of("localhost").unwrap_err().contains("host:port"));
    // No broker and no page: nothing would show the drives.
    let e = Plant::parse(
        "[gateway]\nname = \"gw\"\nbroker = \"off\"\n\
         [[bus]]\nname = \"b\"\nprotocol = \"movilink\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"d\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n",
        "plant.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("broker = \"off\" needs a [ui]"), "{e}");
    let p = plant("");
    assert!(!p.gateway.uses_broker());
    assert_eq!(
        p.ui.as_ref().map(|u| u.listen.ip().is_loopback()),
        Some(true)
    );
}

fn check_ui_of(listen: &str) -> std::result::Result<crate::config::Ui, String> {
    crate::config::check_ui(listen)
}

#[test]
fn only_requests_that_name_this_machine_are_answered() {
    for ok in [
        "localhost",
        "localhost:8080",
        "127.0.0.1",
        "127.0.0.1:18080",
        "127.1.2.3:80",
        "[::1]",
        "[::1]:8080",
    ] {
        assert!(loopback_host(ok), "{ok}");
    }
    for bad in [
        "evil.example",
        "evil.example:8080",
        "localhost.evil.example",
        "192.168.1.2:8080",
        "[::2]:80",
        "",
    ] {
        assert!(!loopback_host(bad), "{bad}");
    }
}

#[test]
fn the_hub_keeps_the_latest_of_each_and_sends_it_to_every_watcher() {
    let hub = Hub::new(plant(""));
    let mut a = hub.subscribe();
    let mut b = hub.subscribe();
    hub.apply(&value(0, 2000));
    hub.apply(&value(0, 2500));
    hub.apply(&Update::Status {
        bus: 0,
        drive: 0,
        status: DriveStatus::Fault("overcurrent".into()),
        at: SystemTime::UNIX_EPOCH,
    });
    // Out of the plant: dropped, nobody told.
    hub.apply(&Update::Value {
        bus: 7,
        drive: 0,
        point: 0,
        raw: 1,
        at: SystemTime::UNIX_EPOCH,
    });
    let v = hub.plant_json();
    let drive = &v["buses"][0]["drives"][0];
    assert_eq!(drive["points"][0]["label"], "P130");
    assert_eq!(drive["points"][0]["writable"], true);
    assert_eq!(drive["points"][0]["latest"]["value"], 2.5);
    assert_eq!(drive["points"][0]["latest"]["unit"], "s");
    assert_eq!(drive["points"][0]["latest"]["ts"], 1000);
    assert_eq!(drive["points"][1]["latest"], Value::Null, "not read yet");
    assert_eq!(drive["points"][1]["period_ms"], 1000);
    assert_eq!(drive["status"]["state"], "fault");
    assert_eq!(drive["status"]["text"], "overcurrent");
    for rx in [&mut a, &mut b] {
        let first: Value = serde_json::from_str(&rx.try_recv().unwrap()).unwrap();
        assert_eq!(
            (&first["type"], &first["point"], &first["payload"]["raw"]),
            (&json!("value"), &json!(0), &json!(2000))
        );
        let _ = rx.try_recv().unwrap();
        let status: Value = serde_json::from_str(&rx.try_recv().unwrap()).unwrap();
        assert_eq!(status["type"], "status");
        assert!(
            rx.try_recv().is_err(),
            "the update out of the plant was sent"
        );
    }
}

/// One HTTP/1.1 request on a fresh connection; the answer's head and as much of the body as
/// arrives within `wait`.
async fn get(addr: SocketAddr, path: &str, host: &str, wait: Duration) -> String {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    s.write_all(
        format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n").as_bytes(),
    )
    .await
    .unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    let deadline = tokio::time::Instant::now() + wait;
    loop {
        match tokio::time::timeout_at(deadline, s.read(&mut buf)).await {
            Ok(Ok(0)) | Err(_) => break,
            Ok(Ok(n)) => got.extend_from_slice(&buf[..n]),
            Ok(Err(e)) => panic!("{e}"),
        }
    }
    String::from_utf8_lossy(&got).into_owned()
}

#[tokio::test]
async fn the_routes_answer_the_plant_the_files_and_a_live_event_stream() {
    let hub = Hub::new(plant(""));
    let listener = bind("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let addr = listener.local_addr().unwrap();
    tokio::spawn(serve(listener, hub.clone(), std::future::pending()));
    hub.apply(&value(0, 2000));

    let page = get(addr, "/", "127.0.0.1", Duration::from_secs(5)).await;
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    assert!(
        page.contains("content-security-policy: default-src 'self'"),
        "{page}"
    );
    assert!(page.contains("<script src=\"/app.js\">"), "{page}");
    let js = get(addr, "/app.js", "localhost", Duration::from_secs(5)).await;
    assert!(
        js.contains("text/javascript") && js.contains("EventSource"),
        "{js}"
    );

    let plant = get(addr, "/api/plant", "localhost:1234", Duration::from_secs(5)).await;
    let body = plant.split("\r\n\r\n").nth(1).unwrap();
    let v: Value = serde_json::from_str(body).unwrap();
    assert_eq!(v["gateway"], "gw");
    assert_eq!(
        v["buses"][0]["drives"][0]["points"][0]["latest"]["raw"],
        2000
    );

    // A rebinding name is refused before any route runs.
    let refused = get(addr, "/api/plant", "evil.example", Duration::from_secs(5)).await;
    assert!(refused.starts_with("HTTP/1.1 421"), "{refused}");
    assert!(!refused.contains("\"gateway\""), "{refused}");

    // The event stream: what happens after the page connects arrives as it happens.
    let stream = tokio::spawn(async move {
        get(
            addr,
            "/api/events",
            "127.0.0.1",
            Duration::from_millis(1500),
        )
        .await
    });
    tokio::time::sleep(Duration::from_millis(300)).await;
    hub.apply(&value(0, 3100));
    let events = stream.await.unwrap();
    assert!(events.contains("text/event-stream"), "{events}");
    let data = events
        .lines()
        .find_map(|l| l.strip_prefix("data: "))
        .unwrap_or_else(|| panic!("no event: {events}"));
    let e: Value = serde_json::from_str(data).unwrap();
    assert_eq!(
        (&e["type"], &e["payload"]["raw"]),
        (&json!("value"), &json!(3100))
    );
}

#[tokio::test]
async fn a_watcher_that_falls_behind_is_told_to_load_the_plant_again() {
    let hub = Hub::new(plant(""));
    let mut rx = hub.subscribe();
    // One more than a watcher may fall behind by: the oldest is gone.
    for i in 0..=EVENTS {
        hub.apply(&value(0, i as i64));
    }
    let behind = event_data(rx.recv().await).unwrap();
    assert_eq!(&*behind, r#"{"type":"resync"}"#);
    // Then the newest ones, as they are.
    let next: Value = serde_json::from_str(&event_data(rx.recv().await).unwrap()).unwrap();
    assert_eq!(next["type"], "value");
    drop(hub);
    let mut left = 0;
    while let Some(_e) = event_data(rx.recv().await) {
        left += 1;
    }
    assert_eq!(
        left,
        EVENTS - 1,
        "every event kept is sent, then the stream ends"
    );
}

#[test]
fn a_plant_of_one_bus_from_the_command_line_is_a_checked_config() {
    for (protocol, port, iface) in [
        ("movilink", Some("/dev/ttyUSB0"), None),
        ("sbus", None, Some("can0")),
        ("uss", Some("/dev/ttyUSB1"), None),
        ("modbus-rtu", Some("/dev/ttyUSB2"), None),
        ("modbus-ascii", Some("/dev/ttyUSB3"), None),
    ] {
        let one = OneBus {
            protocol: protocol.into(),
            port: port.map(Into::into),
            iface: iface.map(Into::into),
            baud: None,
            parity: None,
            addresses: vec![1, 2],
            simulate: false,
            listen: "127.0.0.1:8080".parse().unwrap(),
            timeout_ms: None,
            retries: None,
            echo: false,
            rs485: None,
        };
        let plant = Plant::parse(&one.config(), "the command line")
            .unwrap_or_else(|e| panic!("{protocol}: {e}\n{}", one.config()));
        assert!(!plant.gateway.uses_broker());
        assert_eq!(plant.ui.as_ref().map(|u| u.listen.port()), Some(8080));
        let bus = &plant.buses[0];
        assert_eq!(bus.protocol.name(), protocol);
        assert_eq!(
            bus.name,
            port.or(iface).unwrap().rsplit('/').next().unwrap()
        );
        assert_eq!(bus.drives.len(), 2);
        assert!(bus.drives.iter().all(|d| d.points.len() >= 3), "{protocol}");
        assert!(
            bus.drives[0]
                .points
                .iter()
                .all(|p| p.period.is_some() && !p.writable)
        );
    }
    // A port name with quotes and backslashes stays one TOML string.
    let odd = OneBus {
        protocol: "movilink".into(),
        port: Some(r#"/dev/serial/by-id/usb-"odd"\name"#.into()),
        iface: None,
        baud: Some(19200),
        parity: Some("none".into()),
        addresses: vec![5],
        simulate: false,
        listen: "127.0.0.1:0".parse().unwrap(),
        timeout_ms: Some(200),
        retries: Some(4),
        echo: true,
        rs485: Some(drive_transport::serial::Rs485Config {
            rts_on_send: false,
            rts_after_send: true,
            delay_rts_before_send_ms: 3,
            ..Default::default()
        }),
    };
    let plant = Plant::parse(&odd.config(), "the command line").unwrap();
    assert_eq!(plant.buses[0].name, "usb--odd--name");
    // The line's timeout and retries reach the bus.
    assert_eq!(
        plant.buses[0].timeout,
        std::time::Duration::from_millis(200)
    );
    assert_eq!(plant.buses[0].retries, 4);
    // A pseudo-terminal keeps its directory's name: `0` alone says nothing.
    let pty = OneBus {
        port: Some("/dev/pts/0".into()),
        ..odd.clone()
    };
    let pty_plant = Plant::parse(&pty.config(), "the command line").unwrap();
    assert_eq!(pty_plant.buses[0].name, "pts-0");
    match &plant.buses[0].endpoint {
        crate::config::Endpoint::Serial { path, adapter, .. } => {
            assert_eq!(path, r#"/dev/serial/by-id/usb-"odd"\name"#);
            // The adapter settings of the command line reach the bus.
            assert!(adapter.echo);
            let r = adapter.rs485.unwrap();
            assert!(!r.rts_on_send && r.delay_rts_before_send_ms == 3);
        }
        other => panic!("{other:?}"),
    }
    // The checks are the config's: an address the protocol does not have is refused.
    let bad = OneBus {
        addresses: vec![150],
        ..odd
    };
    let e = Plant::parse(&bad.config(), "the command line")
        .unwrap_err()
        .to_string();
    assert!(e.contains("150"), "{e}");
}

#[test]
fn the_parameter_table_is_searched_in_german_and_english_with_umlauts_folded() {
    let p = plant("");
    let numbers = |term: &str| -> Vec<String> {
        params_json(&p, 0, 0, Some(term)).unwrap()["params"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["number"].as_str().unwrap_or("").to_owned())
            .collect()
    };
    for term in ["Rampe", "ramp", "RAMP t11"] {
        assert!(numbers(term).contains(&"P130".to_owned()), "{term}");
    }
    // "ueberwachung" finds "Überwachung" as the command line's --search does.
    let folded = numbers("ueberwachung");
    assert!(!folded.is_empty());
    assert_eq!(folded, numbers("Überwachung"));
    let all = params_json(&p, 0, 0, None).unwrap();
    assert_eq!(all["family"], "movidrive");
    let rows = all["params"].as_array().unwrap();
    assert!(rows.len() > 100 && rows.len() <= MAX_PARAMS);
    let p130 = rows.iter().find(|r| r["number"] == "P130").unwrap();
    assert_eq!(
        (&p130["unit"], &p130["min"], &p130["max"], &p130["default"]),
        (&json!("s"), &json!(0.0), &json!(2000.0), &json!(2.0))
    );
    assert_eq!(p130["group_en"], "Speed ramps 1");
    assert!(numbers("no such name at all").is_empty());
    assert!(params_json(&p, 0, 5, None).is_none());
    assert!(params_json(&p, 3, 0, None).is_none());
}

/// `drivectl ui ctt2 --sim`: NORD's points on the simulated AS-i link, slow enough that two
/// drives fit its wire (a read takes about 0.7 s there); without `simulate` it is refused, and
/// `--scan` probes the double slaves' numbers 1–31.
#[test]
fn a_one_bus_ctt2_plant_is_simulated_and_its_polls_fit_the_as_i_link() {
    let one = OneBus {
        protocol: "ctt2".into(),
        port: None,
        iface: None,
        baud: None,
        parity: None,
        addresses: vec![1, 5],
        simulate: true,
        listen: "127.0.0.1:8080".parse().unwrap(),
        timeout_ms: None,
        retries: None,
        echo: false,
        rs485: None,
    };
    let plant = Plant::parse(&one.config(), "the command line").unwrap();
    let bus = &plant.buses[0];
    assert_eq!(bus.protocol, crate::config::Protocol::Ctt2);
    let names: Vec<&str> = bus.drives[0]
        .points
        .iter()
        .map(|p| p.name.as_str())
        .collect();
    assert_eq!(names, ["fault", "warning", "max_frequency"]);
    let d = crate::families::demand(bus);
    assert!(d > 0.5 && d < 1.0, "demand {d}");
    assert_eq!(scan_range("ctt2"), (1, 31));
    let real = OneBus {
        simulate: false,
        ..one.clone()
    };
    let e = Plant::parse(&real.config(), "the command line")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no real AS-i master"), "{e}");
    let found = one.scan(1, 8, &mut |_, _| {}).unwrap();
    assert_eq!(found, vec![1, 5]);
}

/// One GET with extra header lines.
async fn get_with(addr: SocketAddr, path: &str, headers: &str) -> String {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    s.write_all(
        format!("GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n{headers}Connection: close\r\n\r\n")
            .as_bytes(),
    )
    .await
    .unwrap();
    let mut got = Vec::new();
    tokio::time::timeout(Duration::from_secs(5), s.read_to_end(&mut got))
        .await
        .unwrap()
        .unwrap();
    String::from_utf8_lossy(&got).into_owned()
}

/// Issue 22, item 2: a reload moves the page to the new plant (the latest of the buses that
/// run on kept, the pages told), and a page that still shows the old plant reaches the drive it
/// means by its old numbers, or is refused (409): never another drive that now has them.
#[tokio::test]
async fn a_reload_moves_the_page_and_old_numbers_reach_their_drive_or_are_refused() {
    let movilink = |name: &str| {
        format!(
            "[[bus]]\nname = \"{name}\"\nprotocol = \"movilink\"\nsimulate = true\n\
             [[bus.drive]]\nname = \"d\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n"
        )
    };
    let modbus = "[[bus]]\nname = \"b\"\nprotocol = \"modbus-rtu\"\nsimulate = true\n\
                  [[bus.drive]]\nname = \"e\"\naddress = 1\n\
                  [[bus.drive.param]]\nparam = \"241\"\nperiod = \"1s\"\n";
    let two = |first: &str, second: &str| {
        Arc::new(
            Plant::parse(
                &format!(
                    "[gateway]\nname = \"gw\"\nbroker = \"off\"\n{first}{second}\
                     [ui]\nlisten = \"127.0.0.1:0\"\n"
                ),
                "test",
            )
            .unwrap(),
        )
    };
    let old = two(&movilink("a"), modbus);
    let hub = Hub::new(old.clone());
    assert_eq!(hub.generation(), 1);
    hub.apply(&Update::Value {
        bus: 1,
        drive: 0,
        point: 0,
        raw: 4200,
        at: SystemTime::now(),
    });
    let mut watcher = hub.subscribe();
    let listener = bind("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let addr = listener.local_addr().unwrap();
    tokio::spawn(serve(listener, hub.clone(), std::future::pending()));

    // Bus b runs on and moves to 0; a goes; c is new at 1.
    let new = two(modbus, &movilink("c"));
    let r = Reconfig {
        generation: 2,
        plant: new.clone(),
        kept: vec![None, Some(0)],
        sets: Vec::new(),
        asks: Vec::new(),
        json: std::sync::Mutex::new(None),
        sparkplug: std::sync::Mutex::new(None),
    };
    assert_eq!(new.buses[0], old.buses[1], "b runs on as it was");
    hub.reconfigure(&r);
    let told: Value = serde_json::from_str(&watcher.recv().await.unwrap()).unwrap();
    assert_eq!(told, json!({"type": "reload", "generation": 2}));
    let v = hub.plant_json();
    assert_eq!(v["generation"], 2);
    assert_eq!(v["buses"][0]["name"], "b");
    assert_eq!(
        v["buses"][0]["drives"][0]["points"][0]["latest"]["raw"], 4200,
        "b's latest came along: {v}"
    );
    assert_eq!(
        v["buses"][1]["drives"][0]["points"][0]["latest"],
        Value::Null
    );
    // Numbers as the old page knows them.
    assert_eq!(hub.resolve(Some(1), 1), Ok(0));
    assert_eq!(hub.resolve(Some(1), 0), Err(Reloaded));
    assert_eq!(hub.resolve(Some(2), 1), Ok(1));
    assert_eq!(hub.resolve(None, 1), Ok(1));
    assert_eq!(hub.resolve(Some(7), 0), Err(Reloaded));

    // Over HTTP: bus 1 of generation 1 is b (the modbus drive `e`), bus 0 of it was a: 409.
    let ok = get_with(
        addr,
        "/api/drive/1/0/params",
        "X-Drivebus-Generation: 1\r\n",
    )
    .await;
    assert!(ok.starts_with("HTTP/1.1 200"), "{ok}");
    assert!(
        ok.contains(r#""bus":"b""#) && ok.contains(r#""drive":"e""#),
        "{ok}"
    );
    let gone = get_with(
        addr,
        "/api/drive/0/0/params",
        "X-Drivebus-Generation: 1\r\n",
    )
    .await;
    assert!(gone.starts_with("HTTP/1.1 409"), "{gone}");
    assert!(gone.contains("reloaded"), "{gone}");
    // Without the header: the current numbers; with a header that is no number: 400.
    let now = get_with(addr, "/api/drive/1/0/params", "").await;
    assert!(now.contains(r#""bus":"c""#), "{now}");
    let bad = get_with(
        addr,
        "/api/drive/1/0/params",
        "X-Drivebus-Generation: x\r\n",
    )
    .await;
    assert!(bad.starts_with("HTTP/1.1 400"), "{bad}");
    // The trend's history by old numbers too.
    let h = get_with(addr, "/api/history/1/0/0", "X-Drivebus-Generation: 1\r\n").await;
    assert!(h.starts_with("HTTP/1.1 200") && h.contains("4200"), "{h}");
}
