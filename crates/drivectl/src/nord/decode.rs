//! `drivectl decode ctt2|uss <HEX...>`: NORD captures explained by `drive_decode::nord`,
//! printed.

use drive_decode::nord::{SettingNames, UssLayout};

use crate::decode::{capture, check_all, print};
use crate::error::Result;

/// The USS layout of `--pkw`, `--pzd` and `--start drive`, its errors naming the options.
pub fn uss_layout(pkw: u8, pzd: Option<u8>, drive_first: bool) -> UssLayout {
    UssLayout {
        pkw,
        pzd,
        drive_first,
        names: SettingNames {
            pkw: Some("--pkw"),
            pzd: Some("--pzd"),
        },
    }
}

/// Run `drivectl decode ctt2` (`uss` None) or `decode uss` with its layout.
pub fn run(uss: Option<UssLayout>, args: &[String], file: Option<&str>, json: bool) -> Result<()> {
    let capture = capture(args, file)?;
    let decoded = match uss {
        Some(layout) => drive_decode::nord::decode_uss(&capture, layout),
        None => drive_decode::nord::decode_ctt2(&capture),
    };
    print(&decoded, json)?;
    check_all(&decoded, "message")
}
