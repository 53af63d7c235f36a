//! Each protocol's [`BusAccess`](super::bus::BusAccess) ([`access`]), opening a bus (its
//! port, which reopens itself after a failure, or simulated drives on the wire model), the
//! wire time of every transaction ([`wire`]), `--check`, and the example config.

pub mod access;
pub mod io;
pub mod wire;

#[cfg(test)]
mod tests;

use bonfiglioli_modbus::framing::Mode;
use drive_core::rt::Stream;
use drive_transport::can::virtual_bus::VirtualBus;
use drive_transport::link::{LinkConfig, pair};

pub use self::access::{Access, Proto};
use self::io::{CanBox, FaultControl, LineIo, Reopen};
pub use self::wire::{WireDesc, demand};
use super::bus::{BusContext, Op};
use super::config::{Bus, Endpoint, Plant, Protocol};
use crate::error::{Error, Result};

/// The commented example config of `drivectl gateway --example-config`.
pub const EXAMPLE_CONFIG: &str = include_str!("example.toml");

/// The simulated endpoint of `bus` (`--simulate`): the same line settings on the wire model.
pub fn simulated_endpoint(bus: &Bus) -> Endpoint {
    match &bus.endpoint {
        Endpoint::Serial { line, .. } => Endpoint::Simulated {
            line: *line,
            bitrate: 500_000,
        },
        Endpoint::Can { .. } => Endpoint::Simulated {
            line: drive_core::LineSettings::new(9600),
            bitrate: wire::bitrate_of(bus).bits_per_second(),
        },
        Endpoint::Simulated { line, bitrate } => Endpoint::Simulated {
            line: *line,
            bitrate: *bitrate,
        },
    }
}

/// The endpoint as a person reads it.
pub fn endpoint_text(e: &Endpoint, protocol: Protocol) -> String {
    match e {
        Endpoint::Serial {
            path,
            line,
            adapter,
        } => {
            let mut text = format!("{path} {line}");
            if adapter.rs485.is_some() {
                text.push_str(" rs485");
            }
            if adapter.echo {
                text.push_str(" echo");
            }
            text
        }
        Endpoint::Can { iface, bitrate } => format!("CAN {iface} at {bitrate} bit/s"),
        // Only the setting the protocol uses: a line for serial buses, a bit rate for SBus.
        Endpoint::Simulated { bitrate, .. } if protocol == Protocol::Sbus => {
            format!("simulated (virtual CAN bus at {bitrate} bit/s)")
        }
        Endpoint::Simulated { .. } if protocol == Protocol::Ctt2 => {
            "the simulated AS-i link".to_owned()
        }
        Endpoint::Simulated { line, .. } => format!("simulated (wire model {line})"),
    }
}

/// `--check`: per bus its wire demand, a line each (the text), and an error if the polls of a
/// bus ask more than its wire carries.
pub fn check_report(plant: &Plant) -> (String, Result<()>) {
    use std::fmt::Write as _;
    let mut text = String::new();
    let mut over = Vec::new();
    for bus in &plant.buses {
        let w = WireDesc::of(bus);
        let d = demand(bus);
        let fits = if d <= 1.0 { "fits" } else { "does not fit" };
        let _ = writeln!(
            text,
            "bus {}: {} on {}, {} drive(s); a read takes {:.2} ms on the wire; the polls ask \
             for {:.1} % of the wire: {fits}",
            bus.name,
            bus.protocol.name(),
            endpoint_text(&bus.endpoint, bus.protocol),
            bus.drives.len(),
            w.time(Op::Read).as_secs_f64() * 1e3,
            d * 100.0
        );
        if d > 1.0 {
            over.push(format!("{} ({:.0} %)", bus.name, d * 100.0));
        }
    }
    if let Some(sp) = &plant.sparkplug {
        let cat = crate::sparkplug::catalogue::Catalogue::new(plant);
        let metrics: usize = cat.node.len()
            + cat
                .devices
                .iter()
                .map(|d| {
                    2 + d.points.len()
                        + d.points.iter().filter(|p| p.result_alias.is_some()).count()
                })
                .sum::<usize>();
        let _ = writeln!(
            text,
            "sparkplug: edge node spBv1.0/{}/…/{}, {} device(s), {metrics} metrics{}{}",
            sp.group_id,
            sp.edge_node_id,
            cat.devices.len(),
            sp.primary_host_id
                .as_deref()
                .map(|h| format!(", waits for primary host {h:?}"))
                .unwrap_or_default(),
            if sp.json {
                ", beside the JSON topics"
            } else {
                ", no JSON topics"
            }
        );
    }
    let verdict = if over.is_empty() {
        Ok(())
    } else {
        Err(Error::failed(format!(
            "the polls ask more than the wire carries on bus {}: lengthen their periods, \
             raise the baud rate or split the bus",
            over.join(", ")
        )))
    };
    (text, verdict)
}

/// What to check when a serial port cannot be opened or fails.
const SERIAL_HINT: &str = "check that the adapter is plugged in, the path (ls /dev/serial/by-id), \
                           its permissions (group dialout) and that no other program uses it";
/// What to check when a CAN interface cannot be opened or fails.
const CAN_HINT: &str = "check that the interface is up (ip link set can0 up type can bitrate \
                        500000) or the slcan adapter is plugged in, and that no other program \
                        holds it";

/// The bus's port, opened on first use and reopened after a failure with a back-off; the
/// adapter's echo taken out when the config says it echoes.
fn serial_line(
    bus: &Bus,
    path: &str,
    line: drive_core::LineSettings,
    adapter: crate::config::Adapter,
) -> LineIo {
    let p = path.to_owned();
    let opener: io::Opener<LineIo> = Box::new(move || {
        let p = p.clone();
        Box::pin(async move {
            open_serial(&p, line, adapter).map(|port| {
                LineIo(Box::new(drive_core::rt::echo::EchoCancel::new(
                    Stream(port),
                    adapter.echo,
                )))
            })
        })
    });
    LineIo(Box::new(Reopen::new(&bus.name, path, SERIAL_HINT, opener)))
}

/// Open the serial port `path` with `line` and the adapter's RS-485 mode (every setting read
/// back); a setting the device refuses names the config key that sets it.
fn open_serial(
    path: &str,
    line: drive_core::LineSettings,
    adapter: crate::config::Adapter,
) -> std::result::Result<drive_transport::serial::SerialPort, String> {
    use drive_transport::LineOption;
    let mut config = drive_transport::serial::SerialConfig::with_line(path, line);
    config.rs485 = adapter.rs485;
    drive_transport::serial::open(&config).map_err(|e| {
        let key = match e.refused_setting() {
            Some(LineOption::Baud) => "baud",
            Some(LineOption::Parity) => "parity",
            Some(LineOption::StopBits) => "stop_bits",
            Some(LineOption::DataBits) => "data_bits",
            Some(LineOption::Rs485) => "rs485",
            _ => return e.to_string(),
        };
        format!("{e} (the bus's {key} in the config)")
    })
}

/// Open the CAN interface named `name`: SocketCAN, or an slcan adapter (its name carries the
/// config's bit rate, see `config`).
async fn open_can(name: &str) -> std::result::Result<CanBox, String> {
    let iface =
        drive_transport::can::Iface::parse(name).map_err(|e| format!("iface = {name:?}: {e}"))?;
    let Some(opened) = iface.open().await else {
        return Err("iface = \"virtual\": write simulate = true for simulated drives".to_owned());
    };
    let port = opened.map_err(|e| e.to_string())?;
    if port.flushed_at_open > 0 {
        tracing::info!(
            iface = name,
            bytes = port.flushed_at_open,
            "discarded what the adapter's port held at opening (left by an earlier program)"
        );
    }
    Ok(port.io)
}

/// The bus's CAN interface, opened on first use and reopened after a failure.
fn can_io(bus: &Bus, iface: &str) -> CanBox {
    let name = iface.to_owned();
    let opener: io::Opener<CanBox> = Box::new(move || {
        let name = name.clone();
        Box::pin(async move { open_can(&name).await })
    });
    Box::new(Reopen::new(&bus.name, iface, CAN_HINT, opener))
}

/// The [`Access`] of `bus` on its configured endpoint (a simulated endpoint gets
/// [`simulated_bus`]). Nothing is opened yet: the port opens on first use, and every failure
/// to open it is logged and makes the bus's transactions fail (its drives `timeout`) until a
/// later attempt succeeds.
pub fn open_bus(bus: &Bus) -> Access {
    let wire = WireDesc::of(bus);
    let proto = match &bus.endpoint {
        Endpoint::Simulated { .. } => return simulated_bus(bus).access,
        Endpoint::Can { iface, .. } => Proto::Sbus(Box::new(access::SbusBus::new(
            can_io(bus, iface),
            bus,
            iface,
        ))),
        Endpoint::Serial { path, adapter, .. } => {
            let line = wire.line;
            let io = serial_line(bus, path, line, *adapter);
            match bus.protocol {
                Protocol::Movilink => Proto::Movilink(Box::new(access::MovilinkBus::new(
                    io, bus, path, line, true,
                ))),
                Protocol::Uss => Proto::Uss(Box::new(access::UssBus::new(io, bus, path, line))),
                Protocol::ModbusRtu => Proto::Modbus(Box::new(access::ModbusBus::new(
                    io,
                    bus,
                    path,
                    Mode::Rtu,
                    line,
                ))),
                Protocol::ModbusAscii => Proto::Modbus(Box::new(access::ModbusBus::new(
                    io,
                    bus,
                    path,
                    Mode::Ascii,
                    line,
                ))),
                // The config gives SBus a CAN interface, never a port, and CTT2 only the
                // simulated AS-i link: run them simulated rather than nowhere.
                Protocol::Sbus | Protocol::Ctt2 => return simulated_bus(bus).access,
            }
        }
    };
    Access {
        proto,
        wire,
        status_slots: Vec::new(),
        control_layouts: Vec::new(),
    }
}

/// A bus of simulated drives: its access, and the switch of its line's faults (the
/// fault-injection and load tests switch them; the gateway runs without).
#[derive(Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub struct SimulatedBus {
    /// The bus as the gateway drives it.
    pub access: Access,
    /// The faults of its serial line (both directions; unused on SBus).
    pub faults: FaultControl,
    /// The virtual CAN bus of an SBus bus (its faults: [`VirtualBus::set_faults`]).
    pub can: Option<VirtualBus>,
}

/// `bus` against simulated drives, one per configured address, each family's simulator on the
/// wire model at the bus's line settings (SBus: on a virtual CAN bus at its bit rate), served
/// by tasks of their own until the access is dropped. Needs a tokio runtime (a paused clock
/// works: the times are the wire model's).
pub fn simulated_bus(bus: &Bus) -> SimulatedBus {
    let wire = WireDesc::of(bus);
    let addresses: Vec<u8> = bus.drives.iter().map(|d| d.address).collect();
    let faults = FaultControl::default();
    let name = format!("simulated:{}", bus.name);
    let line = wire.line;
    let serial = || {
        let (master, drives) = pair(LinkConfig::from_line(line));
        (
            LineIo(Box::new(faults.wrap(master, 0))),
            faults.wrap(drives, 1),
        )
    };
    let (proto, can) = match bus.protocol {
        Protocol::Movilink => {
            let (io, end) = serial();
            let mut sim = movilink::sim::bus(&addresses, line);
            tokio::spawn(async move {
                let _ = sim.serve(end).await;
            });
            let b = access::MovilinkBus::new(io, bus, &name, line, false);
            (Proto::Movilink(Box::new(b)), None)
        }
        Protocol::Uss => {
            let (io, end) = serial();
            let uss: Vec<_> = addresses
                .iter()
                .filter_map(|a| ctt2_uss::serial::UssAddress::new(*a))
                .collect();
            let mut sim = ctt2_uss::serial::sim::bus(&uss, wire.layout, line);
            tokio::spawn(async move {
                let _ = sim.serve(end).await;
            });
            (
                Proto::Uss(Box::new(access::UssBus::new(io, bus, &name, line))),
                None,
            )
        }
        Protocol::Ctt2 => (Proto::Ctt2(Box::new(access::Ctt2Bus::simulated(bus))), None),
        Protocol::ModbusRtu | Protocol::ModbusAscii => {
            let mode = if bus.protocol == Protocol::ModbusRtu {
                Mode::Rtu
            } else {
                Mode::Ascii
            };
            let (io, end) = serial();
            let mut sim = bonfiglioli_modbus::sim::bus(
                &addresses,
                drive_sim::bonfiglioli::Variant::Acu,
                mode,
                line,
            );
            tokio::spawn(async move {
                let _ = sim.serve(end).await;
            });
            let b = access::ModbusBus::new(io, bus, &name, mode, line);
            (Proto::Modbus(Box::new(b)), None)
        }
        Protocol::Sbus => {
            let vbus = VirtualBus::new(wire.bitrate);
            let node = vbus.node();
            let mut sim = sbus_can::sim::SimulatedSbusBus::new(&addresses);
            tokio::spawn(async move {
                let _ = sim.serve(node).await;
            });
            let io: CanBox = Box::new(vbus.node());
            (
                Proto::Sbus(Box::new(access::SbusBus::new(io, bus, &name))),
                Some(vbus),
            )
        }
    };
    SimulatedBus {
        access: Access {
            proto,
            wire,
            status_slots: Vec::new(),
            control_layouts: Vec::new(),
        },
        faults,
        can,
    }
}

/// Open the bus of `ctx` and run its task (a port that fails is reopened with a back-off).
pub async fn run_bus(ctx: BusContext) {
    let access = open_bus(&ctx.bus);
    super::task::run_bus(ctx, access).await;
}
