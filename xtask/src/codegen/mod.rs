//! The generators of the drive families, one folder each, and of sparkplug-b's payload types
//! ([`sparkplug`]).
//!
//! Each family's `mod.rs` has the `generate(dir)` entry point; its submodules each read,
//! validate and render one group of CSV files (usually one generated file). The CSV reader
//! ([`crate::table`]) and the rendering helpers ([`crate::render`]) are shared.

pub mod bonfiglioli;
pub mod nord;
pub mod sew;
pub mod sparkplug;

#[cfg(test)]
mod test_util;
