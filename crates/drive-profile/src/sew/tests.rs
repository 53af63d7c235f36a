//! Tests of the SEW tables against the values printed in the manuals.

use super::*;
use proptest::prelude::*;

fn approx(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + b.abs())
}

#[test]
fn row_counts() {
    // Every printed row of ch. 7.2: 307 rows with a menu number and 85 without.
    assert_eq!(params().len(), 392);
    assert_eq!(params().iter().filter(|p| p.menu.is_some()).count(), 307);
    assert_eq!(params().iter().filter(|p| p.menu.is_none()).count(), 85);
    assert_eq!(groups().len(), 73);
    assert_eq!(units().len(), 105);
    assert_eq!(conversions().len(), 25);
    assert_eq!(return_codes().len(), 20);
}

#[test]
fn p000_speed() {
    let p = by_index(8318).unwrap();
    assert_eq!(p.menu, Some(0));
    assert_eq!(p.menu_label().as_str(), "P000");
    assert_eq!(p.name_de, "Drehzahl [1/min]");
    assert_eq!(p.unit(), "1/min");
    assert_eq!(p.size_index, 11);
    assert_eq!(p.conversion_index, 66);
    assert_eq!(p.access(), Access::READ_ONLY);
    assert!(!p.access().is_writable());
    assert!(approx(p.to_physical(1_000_000), 1000.0));
    assert_eq!(p.from_physical(1000.0), Ok(1_000_000));
    assert_eq!(p.quantity(), Some("speed"));
    let mut out = FixedString::default();
    p.describe_scaling(&mut out).unwrap();
    assert_eq!(
        out.as_str(),
        "size index 11 (speed), conversion index 66: A = 1.667e-5, B = 0; shown in 1/min (conversion index 67)"
    );
    assert_eq!(p.decimals(), 3);
}

/// A small fixed buffer implementing `fmt::Write` (no allocation).
struct FixedString {
    buf: [u8; 256],
    len: usize,
}

impl Default for FixedString {
    fn default() -> Self {
        FixedString {
            buf: [0; 256],
            len: 0,
        }
    }
}

impl FixedString {
    fn as_str(&self) -> &str {
        core::str::from_utf8(&self.buf[..self.len]).unwrap()
    }
}

impl fmt::Write for FixedString {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let end = self.len + s.len();
        self.buf
            .get_mut(self.len..end)
            .ok_or(fmt::Error)?
            .copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

#[test]
fn p813_sbus_address_and_lookup_forms() {
    let p = by_number(813).unwrap();
    assert_eq!(p.name_de, "SBus Adresse");
    assert_eq!(p.index, 8600);
    assert_eq!(p.raw_range(), Some((0, 63)));
    assert_eq!(p.default_raw(), Some(0));
    assert_eq!(p.access(), Access::parse("N/RW").unwrap());
    for s in ["P813", "p813", "813", " 813 ", "8600", "0x2198", "0X2198"] {
        assert_eq!(lookup(s).map(|x| x.index), Some(8600), "{s}");
    }
    assert!(
        lookup("P8600").is_none(),
        "P prefix always means a menu number"
    );
    assert!(lookup("").is_none());
    assert!(lookup("P").is_none());
    assert!(lookup("0x").is_none());
    assert!(lookup("x813").is_none());
    assert!(lookup("99999").is_none());
    assert!(p.in_range(63));
    assert!(!p.in_range(64));
    assert!(p.from_physical(64.0).is_err());
}

#[test]
fn search_finds_names_in_both_languages() {
    let hits: Vec<u16> = search("sbus").filter_map(|p| p.menu).collect();
    assert!(hits.contains(&813), "{hits:?}");
    assert!(hits.contains(&814));
    assert!(search("SBUS ADRESSE").any(|p| p.menu == Some(813)));
    assert!(search("sbus address").any(|p| p.menu == Some(813)));
    assert!(search("kühlkörper").any(|p| p.menu == Some(14)));
    assert!(search("heat sink").count() >= 6);
    assert_eq!(search("no such parameter").count(), 0);
}

#[test]
fn every_hex_index_matches_the_decimal_index() {
    for p in params() {
        assert_eq!(
            u16::from_str_radix(p.index_hex, 16),
            Ok(p.index),
            "{}",
            p.menu_label()
        );
        assert!((0x2000..=0x5FFF).contains(&p.index));
    }
    // P945: the manual prints 2288h for 8891 (= 22BBh); see SEW-E09.
    let p945 = by_number(945).unwrap();
    assert_eq!((p945.index, p945.index_hex), (8891, "22BB"));
    assert!(p945.errata.contains("SEW-E09"));
}

#[test]
fn shared_and_second_indices() {
    // P010 … P013 are all index 8310.
    let menus: Vec<Option<u16>> = all_by_index(8310).map(|p| p.menu).collect();
    assert_eq!(menus, [Some(10), Some(11), Some(12), Some(13)]);
    assert_eq!(by_index(8310).unwrap().menu, Some(10));
    // P852 has two indices; the second one finds it too.
    let p852 = by_number(852).unwrap();
    assert_eq!((p852.index, p852.index2), (8772, Some(8773)));
    assert_eq!(by_index(8773).map(|p| p.menu), Some(Some(852)));
    // Its default is one number, the ASCII text "1/mi" (low byte first); see SEW-E05.
    let d = p852.default.unwrap();
    assert_eq!(d, 1_768_763_185);
    assert_eq!((d as u32).to_le_bytes(), *b"1/mi");
    assert_eq!(all_by_index(8299).count(), 0);
    assert_eq!(all_by_index(0).count(), 0);
    assert_eq!(all_by_index(u16::MAX).count(), 0);
}

#[test]
fn value_lists_and_references() {
    let p870 = by_number(870).unwrap();
    let v = p870.value_name(9).unwrap();
    assert_eq!((v.de, v.en), ("STEUERWORT 1", "control word 1"));
    assert_eq!(p870.default_raw(), Some(9));
    assert_eq!(p870.values().len(), 13);
    let p871 = by_number(871).unwrap();
    assert_eq!(p871.values_ref, Some(870));
    assert!(core::ptr::eq(p871.values(), p870.values()));
    assert_eq!(p871.value_name(1).unwrap().en, "speed");
    assert_eq!(p871.raw_range(), Some((0, 12)));
    // A reference to a reference-free list three sections away: P840 → P802.
    assert_eq!(by_number(840).unwrap().value_name(1).unwrap().de, "JA");
    // Values that contain digits themselves are split right: P700 "0 = VFC 1 1 = VFC 1 & GRUPPE".
    let p700 = by_number(700).unwrap();
    assert_eq!(p700.value_name(0).unwrap().de, "VFC 1");
    assert_eq!(p700.value_name(1).unwrap().de, "VFC 1 & GRUPPE");
    assert_eq!(p700.values().len(), 21);
    assert_eq!(by_number(600).unwrap().values().len(), 26);
    assert_eq!(by_number(620).unwrap().values().len(), 23);
    // "0 = AUS / 1 = EIN" loses the separator.
    assert_eq!(by_number(138).unwrap().value_name(0).unwrap().de, "AUS");
    for p in params() {
        if let (Some(d), false) = (p.default, p.values.is_empty()) {
            assert!(
                p.value_name(d).is_some(),
                "{} default {d} not in its list",
                p.menu_label()
            );
        }
    }
}

#[test]
fn fault_memory_sub_entries() {
    let subs: Vec<&Param> = params().iter().filter(|p| p.parent == Some(80)).collect();
    assert_eq!(subs.len(), 16);
    let p = by_index(8371).unwrap();
    assert_eq!(p.menu, None);
    assert_eq!(p.menu_label().as_str(), "P080.1");
    assert_eq!(p.name_de, "Eingangsklemmen 1...6");
    assert_eq!(p.number(), None);
    assert_eq!(lookup("P080.1").map(|p| p.index), Some(8371));
    assert_eq!(lookup("P080.0").map(|p| p.index), Some(8366));
    assert_eq!(
        lookup("P080.7").map(|p| p.name_de),
        Some("Drehzahl [1/min]")
    );
    assert_eq!(lookup("P080.7").map(|p| p.index), Some(8401));
    // P082 and P083 start at "Fehler t-2" / "Fehler t-3" (SEW-E02).
    assert_eq!(
        by_number(82).map(|p| (p.name_de, p.index)),
        Some(("Fehler t-2", 8368))
    );
    assert_eq!(
        by_number(83).map(|p| (p.name_de, p.index)),
        Some(("Fehler t-3", 8369))
    );
    assert_eq!(
        by_number(84).map(|p| (p.name_de, p.index)),
        Some(("Fehler t-4", 8370))
    );
    for m in [81, 82, 83] {
        assert_eq!(
            params().iter().filter(|p| p.parent == Some(m)).count(),
            16,
            "P0{m}"
        );
    }
    // P084 lacks the active current row (SEW-E04).
    assert_eq!(params().iter().filter(|p| p.parent == Some(84)).count(), 15);
    // Misspelt names are kept as printed (SEW-E03) but found by the English name.
    assert_eq!(
        by_index(8400).unwrap().name_de,
        "Kühlköperfertemperatur [°C]"
    );
    assert_eq!(
        by_index(8400).unwrap().name_en,
        "Heat sink temperature [°C]"
    );
    // The percent variants of the internal setpoints belong to their [1/min] rows (SEW-E11).
    let pct = lookup("P160.1").unwrap();
    assert_eq!(pct.name_de, "interner Sollwert n11 [%]");
    assert_eq!(pct.index, 8489);
    assert_eq!(pct.unit(), "1/min");
}

#[test]
fn md60a_marker() {
    assert!(by_number(220).unwrap().md60a_only);
    assert!(by_number(617).unwrap().md60a_only);
    assert!(!by_number(600).unwrap().md60a_only);
    assert_eq!(params().iter().filter(|p| p.md60a_only).count(), 36);
}

#[test]
fn ranges_with_gaps_and_hex_bounds() {
    let p224 = by_number(224).unwrap();
    assert_eq!(p224.ranges.len(), 2);
    assert_eq!(p224.raw_range(), Some((-99_999_999, 99_999_999)));
    assert!(p224.in_range(-10) && p224.in_range(10));
    assert!(!p224.in_range(0), "the gap -9…9 is not settable");
    assert!(p224.from_physical(5.0).is_err());
    let p900 = by_number(900).unwrap();
    assert_eq!(p900.raw_range(), Some((-0x7FFF_FFFF, 0x7FFF_FFFF)));
    // The fieldbus baud rate prints a 40-bit bound (SEW-E06).
    assert_eq!(by_number(92).unwrap().raw_range(), Some((0, 0xFFFF_FFFF)));
    // Multi-step ramps snap to the step of their segment.
    let p130 = by_number(130).unwrap();
    assert_eq!(p130.from_physical(2.0), Ok(2000));
    assert_eq!(p130.from_physical(0.123), Ok(120));
    assert_eq!(p130.from_physical(12.34), Ok(12_000));
    assert_eq!(p130.decimals(), 2);
    assert!(p130.from_physical(2001.0).is_err());
    assert!(p130.from_physical(f64::NAN).is_err());
}

#[test]
fn defaults_lie_in_their_ranges() {
    for p in params() {
        if let (Some(d), false) = (p.default, p.ranges.is_empty()) {
            assert_eq!(
                p.in_range(d),
                !p.default_outside_range,
                "{}",
                p.menu_label()
            );
        }
    }
}

#[test]
fn units_and_conversions() {
    // 7.3 worked example: 1500 with size index 4 and conversion index -3 is 1.5 s.
    let ms = conversion(-3).unwrap();
    assert_eq!(ms.to_physical(1500), 1.5);
    assert_eq!(unit_of(4, -3).map(|u| u.symbol), Some("ms"));
    assert_eq!(size_name(4), Some("time"));
    // Conversion index 100: raw 25 is 298.15 K, i.e. 25 °C.
    let c = conversion(100).unwrap();
    assert!(approx(c.to_physical(25), 298.15));
    assert!(approx(
        c.rebase(conversion(100).unwrap()).to_physical(25),
        25.0
    ));
    let p014 = by_number(14).unwrap();
    assert_eq!(p014.unit(), "°C");
    assert!(approx(p014.to_physical(25), 25.0));
    assert!(approx(p014.to_physical(-10), -10.0));
    // °F: 5/9 K per step from 255.37 K; 212 °F is (almost) 100 °C.
    let f = conversion(101).unwrap();
    assert!((f.rebase(c).to_physical(212) - 100.0).abs() < 0.01);
    // 69 is printed without a factor.
    assert!(conversion(69).is_none());
    assert!(
        conversions()
            .iter()
            .any(|c| c.index == 69 && c.kind == ConversionKind::Reserved)
    );
    assert!(conversion(99).is_none());
    // The decimal rule reaches beyond the printed rows.
    assert_eq!(conversion(5).map(|l| l.a), Some(100_000.0));
    assert_eq!(conversion(-6).map(|l| l.a), Some(1e-6));
    // Special indices.
    assert!(approx(conversion(66).unwrap().a, 1e-3 / 60.0));
    assert_eq!(conversion(74).unwrap().a, 3600.0);
    assert!(approx(
        conversion(80).unwrap().a,
        core::f64::consts::PI / 180.0
    ));
    // Repaired rows of the size table (SEW-E12).
    assert_eq!(
        unit_by_symbol(12, "gon").map(|u| u.conversion_index),
        Some(81)
    );
    assert_eq!(
        unit_by_symbol(15, "t/h").map(|u| u.conversion_index),
        Some(73)
    );
    assert_eq!(
        unit_by_symbol(16, "MNm").map(|u| u.conversion_index),
        Some(6)
    );
    assert_eq!(unit_by_symbol(17, "K").map(|u| u.conversion_index), Some(0));
    assert_eq!(unit_by_symbol(23, "Ω").map(|u| u.unit_de), Some("Ohm"));
    assert_eq!(
        unit_by_symbol(1, "µm").map(|u| u.conversion_index),
        Some(-6)
    );
    assert_eq!(unit_by_symbol(8, "Ws").map(|u| u.symbol), Some("J"));
    assert_eq!(size_units(16).count(), 3);
    assert_eq!(size_units(17).count(), 3);
}

#[test]
fn display_units_scale_as_printed() {
    // Ramps: ms on the bus, s on display.
    assert!(approx(by_number(130).unwrap().to_physical(2000), 2.0));
    // Filters: µs on the bus, ms on display.
    assert!(approx(by_number(115).unwrap().to_physical(5000), 5.0));
    assert_eq!(by_number(115).unwrap().unit(), "ms");
    // Hours counted in minutes.
    assert!(approx(by_number(15).unwrap().to_physical(90), 1.5));
    // Percent in 1/1000 %.
    assert!(approx(by_number(303).unwrap().to_physical(150_000), 150.0));
    // Boost is a percentage (SEW-E07), not a voltage.
    assert_eq!(by_number(321).unwrap().unit(), "%");
    // Size index 0 values keep their base scaling.
    assert!(approx(by_number(915).unwrap().to_physical(100_000), 100.0));
    assert_eq!(by_number(915).unwrap().unit(), "%");
    assert_eq!(by_number(3).unwrap().unit(), "Inc");
    // mV offsets.
    assert!(approx(by_number(111).unwrap().to_physical(-500), -500.0));
}

#[test]
fn return_codes_decode() {
    let r = return_code_info(8, 0, 0x0010).unwrap();
    assert_eq!(r.de, "Unerlaubter Parameter-Index");
    assert_eq!(r.en, "illegal parameter index");
    assert_eq!(r.error_class().map(|c| c.name), Some("other"));
    let mut out = FixedString::default();
    fmt::write(&mut out, format_args!("{r}")).unwrap();
    assert_eq!(
        out.as_str(),
        "illegal parameter index (error class 8, error code 0, additional code 0x0010)"
    );
    assert_eq!(
        return_code_info(8, 0, 0x001C).map(|r| r.en),
        Some("controller inhibit required")
    );
    assert_eq!(
        return_code_info(8, 0, 0x0020).map(|r| r.de),
        Some("Parameter kann nicht bei freigegebener Endstufe geändert werden")
    );
    assert!(return_code_info(8, 0, 0x0021).is_none());
    assert!(return_code_info(6, 2, 0).unwrap().retry);
    assert_eq!(return_code_info(5, 5, 0).map(|r| r.section), Some("5.2"));
    assert_eq!(
        error_class_info(7).map(|c| c.en),
        Some("error in the object dictionary")
    );
    let d = describe_return_code(5, 3, 0);
    let mut out = FixedString::default();
    fmt::write(&mut out, format_args!("{d}")).unwrap();
    assert_eq!(
        out.as_str(),
        "error during service execution (service) (error class 5, error code 3, additional code 0x0000)"
    );
    let d = describe_return_code(0x42, 0, 0);
    let mut out = FixedString::default();
    fmt::write(&mut out, format_args!("{d}")).unwrap();
    assert!(out.as_str().starts_with("unknown error class"));
}

// ---------------------------------------------------------------------------------------------
// Allocation check: a global allocator that counts allocations per thread.

mod counting {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    pub struct Counting;

    thread_local! {
        pub static COUNT: Cell<usize> = const { Cell::new(0) };
    }

    // SAFETY: forwards every call to `System` unchanged; only counts.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
            // SAFETY: same contract as the caller's.
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: same contract as the caller's.
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new: usize) -> *mut u8 {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
            // SAFETY: same contract as the caller's.
            unsafe { System.realloc(ptr, layout, new) }
        }
    }

    #[global_allocator]
    static GLOBAL: Counting = Counting;

    pub fn allocations_in(f: impl FnOnce()) -> usize {
        let before = COUNT.with(Cell::get);
        f();
        COUNT.with(Cell::get) - before
    }
}

#[test]
fn lookups_do_not_allocate() {
    let mut found = 0usize;
    let n = counting::allocations_in(|| {
        for s in ["P813", "813", "8600", "0x2198", "P080.3", "nonsense"] {
            found += usize::from(lookup(s).is_some());
        }
        found += usize::from(by_index(8318).is_some());
        found += all_by_index(8310).count();
        found += usize::from(by_number(870).is_some());
        found += search("sbus").count();
        found += search("KÜHLKÖRPER").count();
        let p = by_number(0).unwrap();
        let _ = p.to_physical(1000);
        let _ = p.from_physical(3.0);
        let _ = p.menu_label();
        let _ = return_code_info(8, 0, 0x11);
        let mut out = FixedString::default();
        let _ = p.describe_scaling(&mut out);
        let _ = fmt::write(&mut out, format_args!("{}", describe_return_code(1, 2, 3)));
    });
    assert_eq!(n, 0, "lookups allocated {n} times");
    assert!(found > 10);
    // The counter works.
    let n = counting::allocations_in(|| drop(std::hint::black_box(vec![1u8; 16])));
    assert!(n >= 1);
}

// ---------------------------------------------------------------------------------------------
// Round trips

fn ranged() -> Vec<&'static Param> {
    params().iter().filter(|p| !p.ranges.is_empty()).collect()
}

proptest! {
    #[test]
    fn raw_physical_raw_round_trip(pi in 0usize..1000, si in 0usize..16, k in any::<u32>()) {
        let list = ranged();
        let p = list[pi % list.len()];
        let seg = p.ranges[si % p.ranges.len()];
        let steps = (seg.max - seg.min) / seg.step;
        let raw = seg.min + (i64::from(k) % (steps + 1)) * seg.step;
        let v = p.to_physical(raw);
        prop_assert_eq!(p.from_physical(v), Ok(raw), "{} raw {} -> {}", p.menu_label(), raw, v);
    }

    #[test]
    fn lookup_never_panics(s in ".{0,12}") {
        let _ = lookup(&s);
    }
}

proptest! {
    // A search folds both names of every row of the table, twice: 256 cases took 12 s of CPU
    // in a debug build, the slowest test of the workspace; 32 arbitrary strings per run.
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn search_never_panics(s in ".{0,12}") {
        let _ = search(&s).count();
    }
}

#[test]
fn every_ranged_parameter_round_trips_its_bounds_and_default() {
    for p in ranged() {
        for s in p.ranges {
            for raw in [s.min, s.max] {
                assert_eq!(
                    p.from_physical(p.to_physical(raw)),
                    Ok(raw),
                    "{}",
                    p.menu_label()
                );
            }
        }
        if let Some(d) = p.default {
            assert_eq!(
                p.from_physical(p.to_physical(d)),
                Ok(d),
                "{}",
                p.menu_label()
            );
        }
    }
}

#[test]
fn speed_process_data_is_0_2_rpm_per_digit() {
    // The manual's profile example: setpoint 5000 = 1000 1/min; negative speeds are signed.
    assert_eq!(super::speed_from_word(5000), 1000.0);
    assert_eq!(super::speed_from_word((-5000i16) as u16), -1000.0);
    assert!((super::speed_from_word(0x7FFF) - 6553.4).abs() < 1e-9);
}
