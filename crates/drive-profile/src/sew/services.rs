//! The SEW parameter services, written once for every bus a MOVIDRIVE is reached on.
//!
//! A bus gives one call, [`ParamServices::service`]: a parameter channel to a drive and its
//! answer (MOVILINK on RS-485 sends it in an acyclic PARAM telegram, SBus as a parameter
//! request on CAN). Everything else is the same on every bus and written here: reading and
//! writing a value (non-volatile and volatile), reading the minimum, maximum, default, scaling
//! and access attributes, and the manual's rule for the return code 6/2 "internal
//! communication error": repeat the service ([`ParamServices::service_repeated`], at most
//! [`SERVICE_ATTEMPTS`] in all; when it persists the drive needs a power cycle).
//!
//! The services take time only through the bus's call, so the trait is `no_std` and allocates
//! nothing.

use core::future::Future;

use super::channel::{AttributeInfo, ParamChannel, ReturnCode, ScaleInfo};

/// How often a service answered with "internal communication error" (6/2) is sent in all: the
/// manual says to repeat it, and to power-cycle the drive when it persists.
pub const SERVICE_ATTEMPTS: u32 = 3;

/// Whether `code` asks for the service to be repeated (6/2, internal communication error).
pub const fn is_transient(code: ReturnCode) -> bool {
    code.error_class == 6 && code.error_code == 2
}

/// The parameter services of a MOVIDRIVE on one bus; see the [module docs](self). A bus
/// implements [`ParamServices::service`] and [`ParamServices::return_code`]; the services
/// are provided.
pub trait ParamServices {
    /// How a drive is addressed on this bus.
    type Address: Copy;
    /// What a service can fail with; a drive's refusal carries its [`ReturnCode`].
    type Error;

    /// One parameter service: `request` to the drive at `address`, the drive's answer channel,
    /// or why none was taken (a refusal is an error whose [`ParamServices::return_code`] is the
    /// drive's).
    fn service(
        &mut self,
        address: Self::Address,
        request: ParamChannel,
    ) -> impl Future<Output = Result<ParamChannel, Self::Error>>;

    /// The drive's return code, if `error` is its refusal.
    fn return_code(error: &Self::Error) -> Option<ReturnCode>;

    /// `request`, repeated while the drive answers 6/2 ([`is_transient`]), at most
    /// [`SERVICE_ATTEMPTS`] times in all.
    fn service_repeated(
        &mut self,
        address: Self::Address,
        request: ParamChannel,
    ) -> impl Future<Output = Result<ParamChannel, Self::Error>> {
        async move {
            let mut attempts = 0;
            loop {
                attempts += 1;
                match self.service(address, request).await {
                    // The manual: "repeat the read or write service".
                    Err(e)
                        if attempts < SERVICE_ATTEMPTS
                            && Self::return_code(&e).is_some_and(is_transient) => {}
                    done => return done,
                }
            }
        }
    }

    /// Read the value of `index`.
    fn read(
        &mut self,
        address: Self::Address,
        index: u16,
    ) -> impl Future<Output = Result<u32, Self::Error>> {
        data(self.service(address, ParamChannel::read(index)))
    }

    /// Write `value` to `index`, non-volatile (EEPROM). Not for cyclic writes: EEPROMs wear
    /// out; see [`WriteGuard`](crate::guard::WriteGuard) and [`ParamServices::write_volatile`].
    fn write(
        &mut self,
        address: Self::Address,
        index: u16,
        value: u32,
    ) -> impl Future<Output = Result<(), Self::Error>> {
        done(self.service(address, ParamChannel::write(index, value)))
    }

    /// Write `value` to `index`, volatile (RAM, lost at power-off).
    fn write_volatile(
        &mut self,
        address: Self::Address,
        index: u16,
        value: u32,
    ) -> impl Future<Output = Result<(), Self::Error>> {
        done(self.service(address, ParamChannel::write_volatile(index, value)))
    }

    /// Read the smallest settable value of `index`.
    fn read_minimum(
        &mut self,
        address: Self::Address,
        index: u16,
    ) -> impl Future<Output = Result<u32, Self::Error>> {
        data(self.service(address, ParamChannel::read_minimum(index)))
    }

    /// Read the largest settable value of `index`.
    fn read_maximum(
        &mut self,
        address: Self::Address,
        index: u16,
    ) -> impl Future<Output = Result<u32, Self::Error>> {
        data(self.service(address, ParamChannel::read_maximum(index)))
    }

    /// Read the default (factory setting) of `index`.
    fn read_default(
        &mut self,
        address: Self::Address,
        index: u16,
    ) -> impl Future<Output = Result<u32, Self::Error>> {
        data(self.service(address, ParamChannel::read_default(index)))
    }

    /// Read the size and conversion index of `index`.
    fn read_scale(
        &mut self,
        address: Self::Address,
        index: u16,
    ) -> impl Future<Output = Result<ScaleInfo, Self::Error>> {
        let answer = self.service(address, ParamChannel::read_scale(index));
        async move { Ok(ScaleInfo::from_data(answer.await?.data)) }
    }

    /// Read the access attributes of `index` and the next available index.
    fn read_attribute(
        &mut self,
        address: Self::Address,
        index: u16,
    ) -> impl Future<Output = Result<AttributeInfo, Self::Error>> {
        let answer = self.service(address, ParamChannel::read_attribute(index));
        async move { Ok(AttributeInfo::from_data(answer.await?.data)) }
    }
}

/// The data of an answer.
async fn data<E>(answer: impl Future<Output = Result<ParamChannel, E>>) -> Result<u32, E> {
    Ok(answer.await?.data)
}

/// The answer of a write: nothing but that it came.
async fn done<E>(answer: impl Future<Output = Result<ParamChannel, E>>) -> Result<(), E> {
    answer.await.map(drop)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bus whose drive answers each service with the next scripted result.
    struct Scripted {
        answers: [Option<Result<u32, ReturnCode>>; 4],
        calls: usize,
        last: Option<ParamChannel>,
    }

    impl ParamServices for Scripted {
        type Address = u8;
        type Error = ReturnCode;

        async fn service(
            &mut self,
            _: u8,
            request: ParamChannel,
        ) -> Result<ParamChannel, ReturnCode> {
            let answer = self.answers.get_mut(self.calls).and_then(Option::take);
            self.calls += 1;
            self.last = Some(request);
            let answer = answer.unwrap_or(Err(ReturnCode::NOT_IMPLEMENTED));
            answer.map(|v| request.answer(Ok(v)))
        }

        fn return_code(error: &ReturnCode) -> Option<ReturnCode> {
            Some(*error)
        }
    }

    fn bus(answers: [Option<Result<u32, ReturnCode>>; 4]) -> Scripted {
        Scripted {
            answers,
            calls: 0,
            last: None,
        }
    }

    /// Polls a future that never waits (the scripted bus answers at once).
    fn now<F: Future>(f: F) -> F::Output {
        let mut f = core::pin::pin!(f);
        let mut cx = core::task::Context::from_waker(core::task::Waker::noop());
        match f.as_mut().poll(&mut cx) {
            core::task::Poll::Ready(v) => v,
            core::task::Poll::Pending => panic!("the scripted bus never waits"),
        }
    }

    #[test]
    fn each_service_sends_its_channel_and_reads_its_answer() {
        let mut b = bus([
            Some(Ok(1500)),
            Some(Ok(0)),
            Some(Ok(0x0C0B)),
            Some(Ok(0x0002_1F42)),
        ]);
        assert_eq!(now(b.read(1, 8318)), Ok(1500));
        assert_eq!(b.last, Some(ParamChannel::read(8318)));
        assert_eq!(now(b.write_volatile(1, 8470, 500)), Ok(()));
        assert_eq!(b.last, Some(ParamChannel::write_volatile(8470, 500)));
        let scale = now(b.read_scale(1, 8318)).unwrap();
        assert_eq!(scale, ScaleInfo::from_data(0x0C0B));
        assert_eq!(b.last, Some(ParamChannel::read_scale(8318)));
        let attr = now(b.read_attribute(1, 8318)).unwrap();
        assert_eq!(attr, AttributeInfo::from_data(0x0002_1F42));
        assert_eq!(now(b.read(1, 8318)), Err(ReturnCode::NOT_IMPLEMENTED));
    }

    #[test]
    fn only_6_2_is_repeated_and_at_most_three_times() {
        let busy = ReturnCode::INTERNAL_COMMUNICATION_ERROR;
        assert!(is_transient(busy));
        assert!(!is_transient(ReturnCode::READ_ONLY));
        // 6/2 twice, then the answer: three services in all.
        let mut b = bus([Some(Err(busy)), Some(Err(busy)), Some(Ok(7)), None]);
        let r = now(b.service_repeated(1, ParamChannel::read(8318)));
        assert_eq!((r.map(|c| c.data), b.calls), (Ok(7), 3));
        // 6/2 every time: given up after three.
        let mut b = bus([
            Some(Err(busy)),
            Some(Err(busy)),
            Some(Err(busy)),
            Some(Ok(7)),
        ]);
        let r = now(b.service_repeated(1, ParamChannel::read(8318)));
        assert_eq!((r, b.calls), (Err(busy), 3));
        // Any other refusal is not repeated; the plain services never repeat.
        let mut b = bus([Some(Err(ReturnCode::READ_ONLY)), Some(Ok(7)), None, None]);
        let r = now(b.service_repeated(1, ParamChannel::write(8318, 1)));
        assert_eq!((r, b.calls), (Err(ReturnCode::READ_ONLY), 1));
        let mut b = bus([Some(Err(busy)), Some(Ok(7)), None, None]);
        assert_eq!((now(b.read(1, 8318)), b.calls), (Err(busy), 1));
    }
}
