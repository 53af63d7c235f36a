//! I/O for drivebus: serial ports, pseudo-terminals and in-memory links.
//!
//! This is the only crate of the workspace that performs I/O, and it knows nothing about any
//! protocol. Everything it hands out implements tokio's [`AsyncRead`](tokio::io::AsyncRead) and
//! [`AsyncWrite`](tokio::io::AsyncWrite), so protocol drivers are generic over it:
//!
//! - [`serial`]: open a serial port with baud rate, data bits, parity, stop bits and optional
//!   Linux RS-485 mode; every refused setting is reported by name with a hint;
//! - [`ports`]: the machine's serial ports as plain data (type, USB IDs, serial number);
//! - [`pty`]: pseudo-terminal pairs in raw mode, a stand-in for a serial port that other
//!   programs can open;
//! - [`link`]: an in-memory full-duplex line with a wire-time model (characters take
//!   `bits / baud` on tokio's clock), per-character parity flags and deterministic fault
//!   injection;
//! - [`can`]: CAN transports, each a [`CanIo`](drive_core::rt::CanIo): an in-memory virtual bus
//!   with arbitration and frame times, slcan adapters (and a simulated one), SocketCAN and
//!   candump logs (Linux).
//!
//! # Example
//!
//! An 18-byte telegram over a simulated 9600 baud 8E1 line takes 20.625 ms on the wire:
//!
//! ```
//! use std::time::Duration;
//! use tokio::io::{AsyncReadExt, AsyncWriteExt};
//! use drive_transport::link::{self, LinkConfig};
//!
//! # #[tokio::main(flavor = "current_thread", start_paused = true)]
//! # async fn main() -> std::io::Result<()> {
//! let (mut master, mut drive) = link::pair(LinkConfig::new(9600));
//! let start = tokio::time::Instant::now();
//! master.write_all(&[0x02; 18]).await?;
//! master.flush().await?; // waits until the last bit has left the line
//! let on_wire = start.elapsed();
//! assert!(on_wire >= Duration::from_micros(20_625));
//!
//! let mut telegram = [0u8; 18];
//! drive.read_exact(&mut telegram).await?;
//! assert_eq!(telegram, [0x02; 18]);
//! # Ok(())
//! # }
//! ```
//!
//! Opening a real port (here a pty, which needs parity none):
//!
//! ```no_run
//! use drive_transport::{pty::PtyPair, serial};
//!
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() -> Result<(), drive_transport::TransportError> {
//! let pty = PtyPair::open()?;
//! let port = serial::open(&pty.slave_config(9600))?;
//! # drop(port);
//! # Ok(())
//! # }
//! ```
//!
//! # Features
//!
//! `vcan-tests` adds nothing to the library: it turns on the tests against a real SocketCAN
//! interface `vcan0` (README.md says how to set one up).
//!
//! # Unsafe code
//!
//! The ioctls and pseudo-terminal calls need `unsafe`; all of it lives in one private module
//! (`sys`) with a SAFETY comment per call.

#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod can;
mod error;
pub mod link;
pub mod ports;
#[cfg(target_os = "linux")]
pub mod pty;
pub mod serial;
#[cfg(target_os = "linux")]
mod sys;

pub use error::{LineOption, TransportError};
