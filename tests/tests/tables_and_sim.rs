//! The generated tables of every family drive the simulated drive core consistently.

use drive_profile::{Access, Family, ParamMeta};
use drive_sim::{Instant, Persistence, SimError};
use drivebus_tests::{params, sim_drive};

/// Every parameter with a range and a default: the simulated drive starts at that default.
#[test]
fn simulated_drives_start_at_the_table_defaults() {
    for family in Family::ALL {
        let drive = sim_drive(family);
        let mut checked = 0;
        for p in params(family) {
            let (Some(default), sub) = (p.default_raw(), p.sub_index().unwrap_or(0)) else {
                continue;
            };
            // Rows sharing an index share one value: the first row's default wins.
            let first = params(family)
                .into_iter()
                .find(|q| q.bus_index() == p.bus_index() && q.sub_index().unwrap_or(0) == sub);
            if first.map(|q| q.default_raw()) != Some(Some(default)) {
                continue;
            }
            if p.access().contains(Access::DATA_SET) {
                continue; // read per data set; covered by drive-sim's own tests
            }
            assert_eq!(
                drive.read(p.bus_index(), sub),
                Ok(default),
                "{family} index {} ({})",
                p.bus_index(),
                p.name_en()
            );
            checked += 1;
        }
        // The manuals give defaults for most SEW rows, for a few NORD and Bonfiglioli ones.
        let expected = if family == Family::Movidrive { 200 } else { 3 };
        assert!(
            checked >= expected,
            "{family}: only {checked} defaults checked"
        );
    }
}

/// Writing one past a writable parameter's range is refused and changes nothing.
#[test]
fn out_of_range_writes_are_refused_for_every_family() {
    let now = Instant::from_millis(1);
    for family in Family::ALL {
        let mut drive = sim_drive(family);
        let mut refused = 0;
        for p in params(family) {
            let Some((lo, hi)) = p.raw_range() else {
                continue;
            };
            let access = p.access();
            if !access.is_writable() || access.contains(Access::DATA_SET) {
                continue;
            }
            let sub = p.sub_index().unwrap_or(0);
            let before = drive.read(p.bus_index(), sub);
            if hi < i64::MAX {
                let r = drive.write(p.bus_index(), sub, hi + 1, Persistence::Volatile, now);
                assert!(
                    matches!(r, Err(SimError::TooLarge { .. })),
                    "{family} {}: {r:?}",
                    p.name_en()
                );
            }
            if lo > i64::MIN {
                let r = drive.write(p.bus_index(), sub, lo - 1, Persistence::Volatile, now);
                assert!(
                    matches!(r, Err(SimError::TooSmall { .. })),
                    "{family} {}: {r:?}",
                    p.name_en()
                );
            }
            assert_eq!(
                drive.read(p.bus_index(), sub),
                before,
                "{family} {}",
                p.name_en()
            );
            refused += 1;
        }
        assert!(refused > 0, "{family}: no writable parameter with a range");
    }
}

/// Read-only parameters cannot be written through the simulated drive.
#[test]
fn read_only_parameters_stay_read_only() {
    let now = Instant::from_millis(1);
    let mut drive = sim_drive(Family::Movidrive);
    // P000 speed, index 8318, is RO in the manual's table.
    let r = drive.write(8318, 0, 1000, Persistence::Volatile, now);
    assert_eq!(r, Err(SimError::ReadOnly { index: 8318 }));
}

/// Physical ↔ raw round trips at both ends of every range, in every family.
#[test]
fn range_limits_round_trip_through_the_scaling() {
    for family in Family::ALL {
        for p in params(family) {
            let Some((lo, hi)) = p.raw_range() else {
                continue;
            };
            for raw in [lo, hi] {
                let v = p.to_physical(raw);
                assert_eq!(
                    p.from_physical(v),
                    Ok(raw),
                    "{family} {} raw {raw} → {v} {}",
                    p.name_en(),
                    p.unit()
                );
            }
        }
    }
}

/// The spot checks of the foundation issue, through the family-independent view.
#[test]
fn issue_2_spot_checks() {
    let p000 = drive_profile::sew::by_index(8318).expect("index 8318");
    assert_eq!(p000.number(), Some(0));
    assert_eq!(p000.unit(), "1/min");
    assert_eq!((p000.size_index, p000.conversion_index), (11, 66));
    assert_eq!(p000.access(), Access::READ_ONLY);
    assert_eq!(p000.to_physical(1_000_000), 1000.0);

    let p813 = drive_profile::sew::lookup("P813").expect("P813");
    assert_eq!(p813.bus_index(), 8600);
    assert_eq!(p813.raw_range(), Some((0, 63)));

    let b1376 = drive_profile::bonfiglioli::by_number(1376).expect("1376");
    assert_eq!(b1376.raw_range(), Some((1, 247)));
    assert_eq!(b1376.default_raw(), Some(1));
}
