//! The family-generic tool layer: what every protocol's commands share, so that each
//! protocol's command-line module is a thin mapping onto its driver.
//!
//! * [`line`](mod@line): the serial line and master options, the runtime, opening a port;
//! * [`client`]: the [`ParamClient`](client::ParamClient) trait (read/write a parameter by its
//!   table entry), naming parameters on the command line ([`Target`](client::Target)) and turning
//!   typed values into raw ones;
//! * [`front`]: the command line as drive-client's front end (its options in the clients'
//!   messages);
//! * [`write`](mod@write): the one write path (width check always, write guard and EEPROM-wear
//!   log unless forced, read-back);
//! * [`drive_client::wear`]: the EEPROM-wear write log that keeps the guard's rule across runs;
//! * [`backup`]: backup and restore of every family's parameters on the command line
//!   (`drive_client`'s engines, the files, text and JSON); [`progress`]: progress bars;
//! * [`read`](mod@read): reading several parameters in one call;
//! * [`meaning`]: what a raw value means (value names, decoded status and fault words);
//! * [`watch`]: several parameters polled with timestamps (a table, lines, CSV or JSON);
//! * [`stale`]: the notes about bytes discarded as stale (left in the port by an earlier
//!   program, or arrived before a request had left);
//! * [`output`]: values as text or JSON.

#[macro_use]
pub mod output;
pub mod again;
pub mod backup;
pub mod client;
#[macro_use]
pub mod cmd;
#[cfg(test)]
pub mod fake;
pub mod front;
pub mod infile;
pub mod info;
pub mod interrupt;
pub mod line;
pub use drive_client::meaning;
pub mod motor;
pub mod outfile;
pub mod progress;
pub mod read;
pub mod scan;
pub mod simrun;
pub mod stale;
pub mod watch;
pub mod write;
