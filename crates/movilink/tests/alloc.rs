//! Encode, decode, the receiver and the state machines do not allocate: a counting global
//! allocator sees no allocation while they run (it counts the test thread's allocations only).

use drive_core::alloc_count::CountingAllocator;
use movilink::timing::Instant;
use movilink::{
    Address, MasterConfig, MasterEvent, MovilinkMaster, ParamChannel, PduType, Receiver,
    RequestContext, ReturnCode, RxChar, Slave, SlaveConfig, Telegram, decode, encode,
};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

struct Drive(u32);

impl movilink::Backend for Drive {
    fn param(&mut self, _ctx: &RequestContext, req: &ParamChannel) -> Result<u32, ReturnCode> {
        self.0 = self.0.wrapping_add(req.data);
        Ok(self.0)
    }
    fn process_data(&mut self, _ctx: &RequestContext, _output: &[u16], input: &mut [u16]) {
        input.fill(7);
    }
}

impl drive_core::Timers for Drive {}

#[test]
fn nothing_allocates() {
    let a = Address::new(1).unwrap();
    let mut master = MovilinkMaster::new(MasterConfig::default());
    let mut slave = Slave::new(SlaveConfig::new(a), Drive(0));
    let mut rx = Receiver::new(movilink::TelegramFraming::slave(a, Address::NO_GROUP));
    let before = CountingAllocator::count();

    let mut sum = 0usize;
    for (i, t) in PduType::ALL.into_iter().enumerate() {
        let tel = Telegram::request(a, t)
            .with_param(ParamChannel::write(8471, i as u32))
            .with_process_data(&[1, 2, 3]);
        let mut buf = [0u8; 18];
        let n = encode(&tel, &mut buf).unwrap();
        let (back, m) = decode(&buf[..n]).unwrap();
        assert_eq!(back, tel);
        sum += m;
        for (k, b) in buf[..n].iter().enumerate() {
            let _ = rx.handle_char(RxChar::new(
                *b,
                Instant::from_micros(i as u64 * 100_000 + k as u64 * 1146),
            ));
        }
    }

    // A cyclic parameter service with handshake sync, entirely in memory.
    let req = Telegram::request(a, PduType::PARAM_3PD).with_param(ParamChannel::write(8471, 5));
    master.send(req, Instant::ZERO).unwrap();
    let mut now = 0u64;
    let mut done = None;
    let mut buf = [0u8; 18];
    for _ in 0..100 {
        if let Some(n) = master.poll_transmit(Instant::from_micros(now), &mut buf) {
            for b in &buf[..n] {
                now += 1146;
                slave.handle_char(RxChar::new(*b, Instant::from_micros(now)));
            }
        }
        now += 3440;
        slave.handle_timeout(Instant::from_micros(now));
        if let Some(n) = slave.poll_transmit(Instant::from_micros(now), &mut buf) {
            for b in &buf[..n] {
                now += 1146;
                master.handle_char(RxChar::new(*b, Instant::from_micros(now)));
            }
        }
        now += 3440;
        master.handle_timeout(Instant::from_micros(now));
        while let Some(e) = master.poll_event() {
            if let MasterEvent::ParamDone(r) = e {
                done = Some(r);
            }
        }
        while slave.poll_event().is_some() {}
        if master.is_idle() {
            break;
        }
    }

    let after = CountingAllocator::count();
    assert_eq!(done, Some(Ok(5)));
    assert!(sum > 0);
    assert_eq!(
        after - before,
        0,
        "allocations during encode/decode/state machines"
    );
}
