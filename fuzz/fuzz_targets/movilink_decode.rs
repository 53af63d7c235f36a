//! Fuzz the MOVILINK decoder, the character receiver (drive-core's receiver with MOVILINK's
//! framing) and the master and slave state machines fed with the same characters.
//!
//! `cargo fuzz run movilink_decode` (from the `fuzz/` folder), or `scripts/fuzz`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use movilink::timing::Instant;
use movilink::{
    Address, AddressFilter, Backend, CharError, Direction, LineTiming, MovilinkMaster, MasterConfig,
    ParamChannel, PduType, Receiver, RequestContext, ReturnCode, RxChar, Slave, SlaveConfig,
    Telegram, TelegramFraming, decode, encode,
};

/// A drive that answers every read with the index and accepts every write.
struct Echo;

impl Backend for Echo {
    fn param(&mut self, _ctx: &RequestContext, request: &ParamChannel) -> Result<u32, ReturnCode> {
        Ok(u32::from(request.index) ^ request.data)
    }

    fn process_data(&mut self, _ctx: &RequestContext, output: &[u16], input: &mut [u16]) {
        for (i, o) in input.iter_mut().zip(output) {
            *i = !*o;
        }
    }
}

impl drive_core::Timers for Echo {}

fuzz_target!(|data: &[u8]| {
    // 1. The decoder: never panics; whatever it accepts re-encodes to the same bytes.
    if let Ok((t, n)) = decode(data) {
        let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
        let m = encode(&t, &mut buf).expect("a decoded telegram fits the maximum length");
        assert_eq!(m, n);
        assert_eq!(Some(&buf[..m]), data.get(..n));
    }

    // 2. Receivers and state machines: pairs of bytes are (character, gap code); they never
    //    panic, whatever arrives and whenever.
    let own = Address::new(1).unwrap_or(Address::BROADCAST);
    let mut rx_slave = Receiver::new(TelegramFraming::slave(own, Address::NO_GROUP));
    let mut rx_any = Receiver::new(TelegramFraming::new(
        Direction::Response,
        AddressFilter::Any,
        LineTiming::MOVILINK,
    ));
    let mut master = MovilinkMaster::new(MasterConfig::default());
    let mut slave = Slave::new(SlaveConfig::new(own), Echo);
    let request =
        Telegram::request(own, PduType::PARAM_1PD).with_param(ParamChannel::read(8318));
    let _ = master.send(request, Instant::ZERO);
    let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
    let _ = master.poll_transmit(Instant::ZERO, &mut buf);
    let mut t = 0u64;
    for pair in data.chunks(2) {
        let byte = pair.first().copied().unwrap_or(0);
        let code = pair.get(1).copied().unwrap_or(0);
        t += 1146 + u64::from(code & 0x3F) * 200;
        let time = Instant::from_micros(t);
        let c = match code >> 6 {
            0 => RxChar::with_error(byte, time, CharError::Parity),
            1 => RxChar::with_error(byte, time, CharError::Framing),
            _ => RxChar::new(byte, time),
        };
        let _ = rx_slave.handle_char(c);
        let _ = rx_any.handle_char(c);
        master.handle_char(c);
        slave.handle_char(c);
        if let Some(at) = master.poll_timeout().filter(|at| *at <= time) {
            master.handle_timeout(at);
        }
        if let Some(at) = slave.poll_timeout().filter(|at| *at <= time) {
            slave.handle_timeout(at);
        }
        let _ = master.poll_transmit(time, &mut buf);
        let _ = slave.poll_transmit(time, &mut buf);
        while master.poll_event().is_some() {}
        while slave.poll_event().is_some() {}
    }
    let _ = rx_slave.handle_timeout(Instant::MAX);
    let _ = rx_any.handle_timeout(Instant::MAX);
    master.handle_timeout(Instant::MAX);
    slave.handle_timeout(Instant::MAX);
});
