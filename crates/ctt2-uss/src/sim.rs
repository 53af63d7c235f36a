//! What both simulated NORDAC LINK front-ends share (feature `sim`): a parameter order carried
//! out on the drive model [`drive_sim::nord::SimulatedNord`], the same for the USS slave on a
//! serial line ([`serial::sim`](crate::serial::sim)) and the AS-i double slave
//! ([`ctt2::link`](crate::ctt2::link)).

use drive_core::Instant;
use drive_profile::nord::Width;
use drive_sim::nord::{PkwRefusal, SimulatedNord};

use crate::uss::pkw::{DriveError, IndLayout, Order, OrderKind, Reply, Storage};

/// Carry out `order` on `drive` at `now` and give the drive's answer: the value read or
/// written, the number of array elements, or AK 7 with the model's PWE2 error number. The
/// array element and parameter set come from IND by the one rule of section 4.6.1.2
/// ([`IndLayout::of_pnu`]); an AK 11–14 order writes RAM only.
pub fn execute(drive: &mut SimulatedNord, order: &Order, now: Instant) -> Reply {
    let pnu = order.pnu();
    let refused = |r: PkwRefusal| Reply::Error(DriveError(r.number()));
    let address = |array: bool| order.ind().split(IndLayout::of_pnu(pnu), array);
    match order.kind() {
        OrderKind::None => Reply::None,
        OrderKind::Read { array } => {
            let (element, set) = address(array);
            let width = match drive.is_double_word(pnu) {
                Some(true) => Width::DoubleWord,
                _ => Width::Word,
            };
            match drive.read(pnu, element, set, now) {
                Ok(value) => Reply::Value {
                    width,
                    array,
                    value,
                },
                Err(r) => refused(r),
            }
        }
        OrderKind::Write {
            width,
            array,
            storage,
            value,
        } => {
            let (element, set) = address(array);
            let eeprom = storage == Storage::Eeprom;
            match drive.write_width(pnu, element, set, width, value, eeprom, now) {
                Ok(()) => Reply::Value {
                    width,
                    array,
                    value,
                },
                Err(r) => refused(r),
            }
        }
        OrderKind::Count => match drive.array_len(pnu) {
            Ok(n) => Reply::Count(u16::from(n)),
            Err(r) => refused(r),
        },
    }
}
