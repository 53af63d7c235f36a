//! A small test table implementing `ParamMeta`.

use drive_profile::scaling::ScaleError;
use drive_profile::{Access, Family, ParamMeta, ValueName};

pub struct Row {
    pub index: u16,
    pub sub: Option<u16>,
    pub access: &'static str,
    pub default: Option<i64>,
    pub range: Option<(i64, i64)>,
    pub values: &'static [ValueName],
}

impl ParamMeta for Row {
    fn family(&self) -> Family {
        Family::Movidrive
    }
    fn number(&self) -> Option<u16> {
        None
    }
    fn bus_index(&self) -> u16 {
        self.index
    }
    fn sub_index(&self) -> Option<u16> {
        self.sub
    }
    fn name_de(&self) -> &'static str {
        "Testparameter"
    }
    fn name_en(&self) -> &'static str {
        "test parameter"
    }
    fn unit(&self) -> &'static str {
        ""
    }
    fn access(&self) -> Access {
        Access::parse(self.access).unwrap_or(Access::NONE)
    }
    fn default_raw(&self) -> Option<i64> {
        self.default
    }
    fn raw_range(&self) -> Option<(i64, i64)> {
        self.range
    }
    fn range_de(&self) -> &'static str {
        ""
    }
    fn range_en(&self) -> &'static str {
        ""
    }
    fn values(&self) -> &'static [ValueName] {
        self.values
    }
    fn decimals(&self) -> u8 {
        0
    }
    fn to_physical(&self, raw: i64) -> f64 {
        raw as f64
    }
    fn from_physical(&self, value: f64) -> Result<i64, ScaleError> {
        Ok(value.round() as i64)
    }
}

const fn row(index: u16, access: &'static str, default: Option<i64>) -> Row {
    Row {
        index,
        sub: None,
        access,
        default,
        range: None,
        values: &[],
    }
}

const fn ranged(index: u16, access: &'static str, default: i64, lo: i64, hi: i64) -> Row {
    Row {
        index,
        sub: None,
        access,
        default: Some(default),
        range: Some((lo, hi)),
        values: &[],
    }
}

static ON_OFF: [ValueName; 2] = [
    ValueName {
        value: 0,
        de: "AUS",
        en: "off",
    },
    ValueName {
        value: 1,
        de: "EIN",
        en: "on",
    },
];

pub const ACTUAL_SPEED: u16 = 8318;
pub const STATUS: u16 = 8310;
pub const RAMP_UP: u16 = 8470;
pub const MOTOR_DATA: u16 = 8500;
pub const LOCK: u16 = 8595;
pub const ADDRESS: u16 = 8600;
pub const SETTING: u16 = 8601;
pub const FACTORY: u16 = 8594;
pub const ARRAY: u16 = 700;
pub const DATA_SET: u16 = 372;
pub const NO_RUN: u16 = 400;
pub const NO_DEFAULT: u16 = 9000;
pub const VOLATILE_RW: u16 = 9001;

pub static TABLE: [Row; 15] = [
    // actual speed, RO, no N
    row(ACTUAL_SPEED, "RO", Some(0)),
    // four rows sharing index 8310 (SEW P010…P013)
    row(STATUS, "N/RO", None),
    row(STATUS, "N/RO", Some(7)),
    row(STATUS, "N/RO", Some(9)),
    // ramp up, N/RW, 0…2 000 000 ms
    ranged(RAMP_UP, "N/RW", 2000, 0, 2_000_000),
    // motor data, N/R/RW
    ranged(MOTOR_DATA, "N/R/RW", 100, 0, 1000),
    // parameter lock, N/S/RW, 0/1
    Row {
        index: LOCK,
        sub: None,
        access: "N/S/RW",
        default: Some(0),
        range: Some((0, 1)),
        values: &ON_OFF,
    },
    // address, N/S/RW
    ranged(ADDRESS, "N/S/RW", 0, 0, 99),
    // a setting with a value list 0/1 but a wider range
    Row {
        index: SETTING,
        sub: None,
        access: "N/RW",
        default: Some(0),
        range: Some((0, 5)),
        values: &ON_OFF,
    },
    // factory setting command, R/RW (no N)
    ranged(FACTORY, "R/RW", 0, 0, 1),
    // an array: sub-indices 0 and 1
    Row {
        index: ARRAY,
        sub: Some(0),
        access: "N/RW",
        default: Some(10),
        range: Some((0, 100)),
        values: &[],
    },
    Row {
        index: ARRAY,
        sub: Some(1),
        access: "N/RW",
        default: Some(11),
        range: Some((0, 100)),
        values: &[],
    },
    // a data-set parameter (Bonfiglioli style)
    ranged(DATA_SET, "N/RW/DS", 1500, 0, 60000),
    // not writable in operation
    ranged(NO_RUN, "N/RW/NOP", 50, 0, 400),
    // no default, no range, RW without N
    row(NO_DEFAULT, "RW", None),
];

pub static EXTRA: [Row; 1] = [row(VOLATILE_RW, "RW", Some(3))];
