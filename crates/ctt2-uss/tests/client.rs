//! The shared master logic (`ctt2_uss::client`) against a fake parameter channel that behaves
//! as section 4.6.1.1 says: until an order is done the drive keeps answering the previous one.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use std::collections::HashMap;

use ctt2_uss::client::{
    Address, ClientConfig, ClientError, NordClient, ParameterChannel, ProcessChannel,
};
use ctt2_uss::uss::DriveError;
use ctt2_uss::uss::pkw::{Order, OrderKind, Pkw, Reply, Storage};
use ctt2_uss::uss::pzd::{PzdIn, PzdOut};
use drive_profile::nord::{State, StatusWord, Width};

#[derive(Debug, thiserror::Error)]
#[error("fake transport error")]
struct FakeError;

/// A drive whose answers lag: an order is done after `delay` further requests.
#[derive(Default)]
struct LaggingDrive {
    values: HashMap<(u16, u16), i32>,
    delay: u32,
    /// The answer sent until the pending order is done.
    current: Pkw,
    pending: Option<(Pkw, u32)>,
    /// Every order submitted, in order.
    submitted: Vec<Pkw>,
    requests: u32,
    /// Never finish orders.
    stuck: bool,
}

impl LaggingDrive {
    fn execute(&mut self, pkw: Pkw) -> Pkw {
        let order = Order::from_pkw(&pkw).unwrap();
        let key = (order.pnu(), order.ind().0);
        let reply = match order.kind() {
            OrderKind::None => Reply::None,
            OrderKind::Read { array } => match self.values.get(&key) {
                Some(v) => Reply::Value {
                    width: Width::Word,
                    array,
                    value: *v,
                },
                None => Reply::Error(DriveError(0)),
            },
            OrderKind::Write { value, array, .. } => {
                if value > 1000 {
                    Reply::Error(DriveError(2))
                } else {
                    self.values.insert(key, value);
                    Reply::Value {
                        width: Width::Word,
                        array,
                        value,
                    }
                }
            }
            OrderKind::Count => Reply::Count(3),
        };
        reply.to_pkw(order.pnu(), order.ind())
    }

    fn step(&mut self) -> Pkw {
        self.requests += 1;
        if let Some((pkw, left)) = self.pending {
            if left == 0 && !self.stuck {
                self.current = self.execute(pkw);
                self.pending = None;
            } else {
                self.pending = Some((pkw, left.saturating_sub(1)));
            }
        }
        self.current
    }
}

impl ParameterChannel for LaggingDrive {
    type Error = FakeError;

    async fn submit(&mut self, order: Pkw) -> Result<Pkw, FakeError> {
        self.submitted.push(order);
        self.pending = Some((order, self.delay));
        Ok(self.step())
    }

    async fn poll(&mut self, _order: Pkw) -> Result<Pkw, FakeError> {
        Ok(self.step())
    }
}

impl ProcessChannel for LaggingDrive {
    type Error = FakeError;

    async fn exchange_process(&mut self, _out: PzdOut, _actuals: u8) -> Result<PzdIn, FakeError> {
        self.requests += 1;
        let actuals = [0u16; 3];
        Ok(PzdIn::new(StatusWord(0x0B70), &actuals[..3]))
    }
}

fn client(delay: u32) -> NordClient<LaggingDrive> {
    let mut drive = LaggingDrive {
        delay,
        ..LaggingDrive::default()
    };
    drive.values.insert((102, 0x0200), 1000);
    drive.values.insert((105, 0), 500);
    NordClient::new(drive, ClientConfig::default())
}

#[tokio::test]
async fn a_lagging_answer_is_asked_for_again() {
    let mut c = client(3);
    let at = Address {
        pnu: 102,
        element: None,
        set: 2,
    };
    assert_eq!(c.read(at).await.unwrap(), 1000);
    // "No order" first (answered at once: the fake drive's power-on answer is AK 0), then the
    // read submitted once and asked for three more times before it was done.
    assert_eq!(c.channel().requests, 5);
    assert_eq!(c.repeated_requests(), 3);
    c.write(Address::new(105), Width::Word, Storage::Ram, 600)
        .await
        .unwrap();
    assert_eq!(c.read(Address::new(105)).await.unwrap(), 600);
}

#[tokio::test]
async fn the_same_order_twice_is_separated_by_no_order() {
    let mut c = client(1);
    assert_eq!(c.read(Address::new(105)).await.unwrap(), 500);
    c.channel_mut().values.insert((105, 0), 123);
    // Without the separation the first answer (500, still repeated) would pass for the second.
    assert_eq!(c.read(Address::new(105)).await.unwrap(), 123);
    let aks: Vec<u8> = c.channel().submitted.iter().map(|p| p.pke.ak()).collect();
    // "No order" before the first order (the drive may still answer an earlier session's
    // order) and between the two reads.
    assert_eq!(aks, [0, 1, 0, 1]);
}

#[tokio::test]
async fn refusals_are_typed_and_stuck_drives_give_up() {
    let mut c = client(0);
    match c
        .write(Address::new(105), Width::Word, Storage::Eeprom, 5000)
        .await
    {
        Err(ClientError::Drive { error, order }) => {
            assert_eq!(error, DriveError(2));
            assert_eq!(order.ak(), 2);
        }
        other => panic!("{other:?}"),
    }
    match c.read(Address::new(999)).await {
        Err(ClientError::Drive { error, .. }) => assert_eq!(error, DriveError(0)),
        other => panic!("{other:?}"),
    }
    assert_eq!(c.count(480).await.unwrap(), 3);

    let mut stuck = NordClient::new(
        LaggingDrive {
            stuck: true,
            ..LaggingDrive::default()
        },
        ClientConfig {
            max_polls: 5,
            ..ClientConfig::default()
        },
    );
    match stuck.read(Address::new(105)).await {
        Err(ClientError::NoPlausibleAnswer { polls, .. }) => assert_eq!(polls, 6),
        other => panic!("{other:?}"),
    }
    // Refused before anything is sent: a word cannot carry 70000, an element above 63 does not fit.
    let sent = stuck.channel().submitted.len();
    assert!(matches!(
        stuck
            .write(Address::new(105), Width::Word, Storage::Eeprom, 70_000)
            .await,
        Err(ClientError::Pkw(_))
    ));
    // P102 has parameter sets: its elements end at 63. P543 has none: set 2 does not exist.
    for bad in [
        Address {
            pnu: 102,
            element: Some(64),
            set: 0,
        },
        Address {
            pnu: 543,
            element: Some(1),
            set: 1,
        },
    ] {
        assert!(matches!(stuck.read(bad).await, Err(ClientError::Pkw(_))));
    }
    assert_eq!(stuck.channel().submitted.len(), sent);
}

/// Erratum E21: AK 7 fits every order, so the refusal of a write would pass for the answer to a
/// read of the same parameter and index that follows it, while the drive still works on the
/// read. The client separates any two orders on one PNU and IND with "no order".
#[tokio::test]
async fn a_refusal_is_not_taken_for_the_next_order_on_the_same_parameter() {
    let mut c = client(2);
    let at = Address::new(105);
    assert!(matches!(
        c.write(at, Width::Word, Storage::Eeprom, 5000).await,
        Err(ClientError::Drive { .. })
    ));
    assert_eq!(c.read(at).await.unwrap(), 500);
    let aks: Vec<u8> = c.channel().submitted.iter().map(|p| p.pke.ak()).collect();
    assert_eq!(aks, [0, 2, 0, 1]);
}

/// A parameter set beyond 4 is refused before any control word is sent (it used to fall back
/// to set 1 silently).
#[tokio::test]
async fn drive_to_refuses_a_parameter_set_past_4() {
    let mut c = client(0);
    assert!(matches!(
        c.drive_to(State::OperationEnabled, &[0x2000], 4).await,
        Err(ClientError::Pkw(_))
    ));
    assert_eq!(c.channel().requests, 0);
    // Set 4 (3, 0-based) is fine: the fake drive stays in switch-on disabled, so the state is
    // not reached, but control words were sent.
    assert!(matches!(
        c.drive_to(State::OperationEnabled, &[0x2000], 3).await,
        Err(ClientError::StateNotReached { .. })
    ));
    assert!(c.channel().requests > 0);
}
