//! The SBus master's timing: its configuration from the options, the least response timeout
//! an answer can meet at the bit rate, and `line`.

use super::*;

pub fn handshake(args: &SbusArgs) -> Handshake {
    if args.handshake == "sync" {
        Handshake::Sync
    } else {
        Handshake::Async
    }
}

pub use sbus_can::master::least_response_timeout as least_timeout;

/// Refuse a response timeout no answer could meet (as `drivectl movilink` and `uss` refuse
/// one shorter than the drive's start pause). A SocketCAN interface's bit rate is the
/// interface's: the slowest SBus rate (125 kbit/s) is the bound then.
pub fn check_timeout(config: &MasterConfig, rate: Bitrate, iface: &Iface) -> Result<()> {
    let rate = match iface {
        Iface::SocketCan(_) => Bitrate::K125,
        _ => rate,
    };
    let least = least_timeout(rate, config.handshake);
    crate::tool::line::check_timeout(
        config.response_timeout,
        least,
        &format!(
            "a parameter answer takes at {} ({:.2} ms: request and response frames and the \
             drive's 1 ms answer window{})",
            match iface {
                Iface::SocketCan(name) => format!("the slowest SBus rate, 125 kbit/s, on {name}"),
                _ => format!("{} kbit/s", rate.bits_per_second() / 1000),
            },
            least.as_secs_f64() * 1e3,
            if config.handshake == Handshake::Sync {
                ", and the SYNC that releases it"
            } else {
                ""
            }
        ),
    )
}

pub fn master_config(args: &SbusArgs) -> MasterConfig {
    MasterConfig {
        response_timeout: Duration::from_millis(args.timeout),
        retries: args.retries,
        sync_id: args.sync_id,
        handshake: handshake(args),
        ..MasterConfig::default()
    }
}

/// `line`: the interface and the timing the master uses on it.
pub fn line(args: &SbusArgs, iface: &Iface, json: bool) -> Result<()> {
    let given = iface::parse_bitrate(&args.bitrate)?;
    let (rate, known) = match iface {
        Iface::SocketCan(_) => (Bitrate::K125, false),
        _ => (iface.bitrate().unwrap_or(given), true),
    };
    let config = master_config(args);
    let us = |d: Duration| d.as_nanos() as f64 / 1000.0;
    let frame = sbus_can::busload::frame_time(8, rate);
    let least = least_timeout(rate, config.handshake);
    if json {
        return outln!(
            "{}",
            json!({
                "iface": args.iface, "bitrate": known.then_some(rate.bits_per_second()),
                "frame_8_bytes_us": known.then_some(us(frame)),
                "least_timeout_us": us(least),
                "response_timeout_ms": config.response_timeout.as_millis() as u64, "address": args.addr,
                "retries": config.retries, "handshake": args.handshake,
                "sync_id": args.sync_id,
            })
        );
    }
    if known {
        outln!(
            "{} at {} kbit/s: an 8-byte frame takes at most {:.1} µs; a parameter answer at \
             least {:.2} ms",
            iface.name(),
            rate.bits_per_second() / 1000,
            us(frame),
            least.as_secs_f64() * 1e3
        )?;
    } else {
        outln!(
            "{} at the bit rate `ip link` set (at 125 kbit/s, the slowest SBus rate, a \
             parameter answer takes at least {:.2} ms)",
            iface.name(),
            least.as_secs_f64() * 1e3
        )?;
    }
    outln!(
        "response timeout {} ms, {} retries, {} handshake, SYNC identifier {}",
        config.response_timeout.as_millis(),
        config.retries,
        args.handshake,
        args.sync_id
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(ms: u64, handshake: Handshake) -> MasterConfig {
        MasterConfig {
            response_timeout: Duration::from_millis(ms),
            handshake,
            ..MasterConfig::default()
        }
    }

    #[test]
    fn issue18_a_timeout_no_answer_can_meet_is_refused_as_movilink_refuses_it() {
        // 500 kbit/s: 2 × 270 µs frames + the 1 ms answer window = 1.54 ms.
        assert_eq!(
            least_timeout(Bitrate::K500, Handshake::Async),
            Duration::from_micros(1540)
        );
        let slcan = Iface::parse("slcan:/dev/x@500k").unwrap();
        let e = check_timeout(&config(1, Handshake::Async), Bitrate::K500, &slcan).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("use --timeout 2 or more"), "{e}");
        check_timeout(&config(2, Handshake::Async), Bitrate::K500, &slcan).unwrap();
        // Sync mode waits for the SYNC too; 125 kbit/s frames are four times longer.
        assert!(check_timeout(&config(2, Handshake::Sync), Bitrate::K500, &slcan).is_err());
        let slow = Iface::parse("slcan:/dev/x@125k").unwrap();
        assert!(check_timeout(&config(3, Handshake::Async), Bitrate::K125, &slow).is_err());
        check_timeout(&config(4, Handshake::Async), Bitrate::K125, &slow).unwrap();
        // SocketCAN: the interface's rate is not known here; the slowest SBus rate bounds it.
        let can0 = Iface::parse("can0").unwrap();
        assert!(check_timeout(&config(3, Handshake::Async), Bitrate::M1, &can0).is_err());
        check_timeout(&config(50, Handshake::Sync), Bitrate::M1, &can0).unwrap();
    }
}
