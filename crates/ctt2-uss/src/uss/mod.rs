//! USS data as NORD drives carry it: the parameter channel ([`pkw`]) and process data ([`pzd`]),
//! the same on the RS-485 port (inside USS serial telegrams) and over AS-i (inside CTT2
//! messages).

pub mod pkw;
pub mod pzd;

pub use pkw::{
    DriveError, Ind, IndLayout, Order, OrderKind, PKW_LEN, Pke, Pkw, PkwError, Plausibility, Reply,
    Storage,
};
pub use pzd::{PzdError, PzdIn, PzdOut};

#[cfg(test)]
mod tests;
