//! CAN transports: everything here is a [`CanIo`](drive_core::rt::CanIo), so the CAN masters
//! and simulated drives run unchanged on any of them.
//!
//! | transport | module | use |
//! |---|---|---|
//! | in-memory bus with arbitration, frame times and fault injection | [`virtual_bus`] | tests, simulators, `--iface virtual` |
//! | slcan (Lawicel ASCII) adapter on a serial port, and a simulated adapter | [`slcan`] | USB-CAN adapters, `slcan:/dev/ttyACM0` |
//! | SocketCAN (Linux) | `socketcan` | `can0`, `vcan0` |
//! | candump log files: read, write, capture, replay | `candump` | logs from and for `candump`/`canplayer` |
//!
//! The SocketCAN and candump modules exist on Linux only (they use the `socketcan` crate).
//!
//! # Example
//!
//! Two nodes on a 500 kbit/s virtual bus; the frame's arrival time is exact on the paused
//! clock:
//!
//! ```
//! use drive_core::can::{Bitrate, CanFrame};
//! use drive_core::rt::{recv_frame, send_frame};
//! use drive_transport::can::VirtualBus;
//!
//! # #[tokio::main(flavor = "current_thread", start_paused = true)]
//! # async fn main() -> std::io::Result<()> {
//! let bus = VirtualBus::new(Bitrate::K500);
//! let (mut a, mut b) = (bus.node(), bus.node());
//! let frame = CanFrame::standard(0x10B, &[0, 6, 0x13, 0x88, 0, 0]).unwrap();
//! let start = tokio::time::Instant::now();
//! let (sent, got) = tokio::join!(send_frame(&mut a, &frame), recv_frame(&mut b));
//! sent?;
//! let got = got?;
//! assert_eq!(got.frame, frame);
//! assert_eq!(got.at - start, frame.duration(Bitrate::K500));
//! # Ok(())
//! # }
//! ```

#[cfg(target_os = "linux")]
pub mod candump;
pub mod iface;
pub mod slcan;
#[cfg(target_os = "linux")]
pub mod socketcan;
pub mod virtual_bus;

pub use iface::{BitrateError, Iface, IfaceError, OpenedPort, parse_bitrate};
pub use slcan::{SlcanAdapter, SlcanPort};
#[cfg(target_os = "linux")]
pub use socketcan::SocketCanPort;
pub use virtual_bus::{BusConfig, BusFault, BusFaults, NodeStats, VirtualBus, VirtualNode};
