//! `NordParamClient` against the fake NORD drive of [`crate::testing::nord`]: what is sent (AK,
//! PNU, IND, PWE) for parameter sets and array elements, the plausibility repeat, refusals and
//! the JSON that names set and element.

use ctt2_uss::client::{ClientConfig, NordClient};
use drive_profile::Persistence;
use drive_profile::nord;
use serde_json::{Map, json};

use super::*;
use crate::target::nord_subs;
use crate::testing::nord::Fake;

fn client(fake: Fake) -> NordClient<Fake> {
    NordClient::new(fake, ClientConfig::default())
}

fn one(key: &str, array: Option<u8>, set: Option<u8>) -> Target {
    let v = resolve(key, array, set, false).unwrap();
    assert_eq!(v.len(), 1);
    v[0]
}

#[tokio::test]
async fn a_write_and_its_read_back_send_the_manuals_orders_and_wait_for_a_plausible_answer() {
    // The drive answers an order only after two more requests (it repeats its previous
    // answer meanwhile): the client asks again until AK, PNU and IND fit.
    let mut c = client(Fake {
        delay: 2,
        ..Fake::default()
    });
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    let p102 = one("P102", None, Some(3));
    pc.write(&p102, 1000, Persistence::NonVolatile)
        .await
        .unwrap();
    assert_eq!(pc.read(&p102).await.unwrap(), 1000);
    let p543 = one("P543", Some(2), None);
    pc.write(&p543, 3, Persistence::Volatile).await.unwrap();
    assert_eq!(pc.read(&p543).await.unwrap(), 3);
    let p102 = one("P102", None, Some(2));
    pc.write(&p102, 250, Persistence::Volatile).await.unwrap();
    assert!(c.repeated_requests() > 0);
    assert_eq!(
        c.channel().orders(),
        [
            // AK 0 first: the drive may still answer an earlier command's order (E21).
            (0, 0, 0, 0),
            // AK 2 (word, EEPROM as P560 says) P102 = 66h, IND 0200h (set 3), 3E8h.
            (2, 0x66, 0x0200, 0x03E8),
            // AK 0 between two orders on one PNU and IND (E21), then AK 1: read it back.
            (0, 0, 0, 0),
            (1, 0x66, 0x0200, 0),
            // AK 12 (array word, RAM only) P543 = 21Fh, IND 0100h ([-02]).
            (12, 0x21F, 0x0100, 3),
            // AK 6: read the element.
            (0, 0, 0, 0),
            (6, 0x21F, 0x0100, 0),
            // AK 14 (word, RAM only), IND 0100h (set 2): 2.5 s as in 5.1.5.
            (14, 0x66, 0x0100, 0xFA),
        ]
    );
}

#[tokio::test]
async fn refusals_are_typed_with_their_pwe2_meaning() {
    let mut c = client(Fake::default());
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    let p700 = one("P700", Some(1), None);
    match pc.write(&p700, 5, Persistence::NonVolatile).await {
        Err(ClientError::Device(d)) => {
            assert_eq!(d.kind, DeviceErrorKind::Refused);
            // The message is the drive's; the caller names the parameter (once).
            assert!(
                !d.message.contains("P700")
                    && d.message
                        .contains("error 1: parameter value cannot be changed")
                    && d.message.contains("read-only"),
                "{}",
                d.message
            );
        }
        other => panic!("{other:?}"),
    }
    let raw = one("900", None, None);
    match pc.read(&raw).await {
        Err(ClientError::Device(d)) => assert_eq!(d.kind, DeviceErrorKind::Absent),
        other => panic!("{other:?}"),
    }
}

#[test]
fn words_of_unsigned_parameters_are_unsigned() {
    let p102 = one("P102", None, None);
    assert_eq!(raw_of(&p102, -1, nord::Width::Word), 65535);
    let raw = one("900", None, None);
    assert_eq!(raw_of(&raw, -1, nord::Width::Word), -1);
}

#[test]
fn issue18_read_json_names_the_set_and_the_array_element_in_the_selector() {
    let v = crate::meaning::value_json(&one("P102", None, Some(3)), 1000);
    assert_eq!(
        (
            &v["index"],
            &v["label"],
            &v["selector"],
            &v["raw"],
            &v["value"]
        ),
        (
            &json!(102),
            &json!("P102 set 3"),
            &json!({"set": 3, "ind": "0x0200"}),
            &json!(1000),
            &json!(10.0)
        )
    );
    let v = crate::meaning::value_json(&one("P700", Some(2), None), 0);
    assert_eq!(v["selector"], json!({"array": 2, "ind": "0x0100"}));
    assert_eq!(v["label"], "P700 [-02]");
    assert_eq!(v["name_en"], "present warning");
    assert_eq!(v["meaning"], "no warning");
    // A parameter with neither: no selector.
    let v = crate::meaning::value_json(&one("P560", None, None), 1);
    assert_eq!(v["selector"], serde_json::Value::Null);
}

#[test]
fn backup_rows_cover_every_element_and_set_with_p560_last() {
    let subs = nord_subs(102);
    assert_eq!(subs, [0x0000, 0x0100, 0x0200, 0x0300]);
    assert_eq!(nord_subs(543), [0x0000, 0x0100, 0x0200]);
    assert_eq!(nord_subs(560), [0]);
}

#[tokio::test]
async fn e21_a_read_after_a_refused_write_of_the_same_parameter_is_not_taken_for_refused() {
    // A slow drive (two requests per order): the write of 400 s is refused (AK 7, error 2),
    // and the drive keeps sending that answer until the read is done. AK 7 fits every order
    // and PNU and IND are the same, so without "no order" in between the read would report
    // the write's refusal (erratum E21).
    let mut c = client(Fake {
        delay: 2,
        ..Fake::default()
    });
    c.channel_mut().values.insert((102, 0x0200), 1000);
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    let p102 = one("P102", None, Some(3));
    assert!(matches!(
        pc.write(&p102, 40_000, Persistence::Volatile).await,
        Err(ClientError::Device(_))
    ));
    assert_eq!(pc.read(&p102).await.unwrap(), 1000);
    // The same in a new command (a new client on the same line): the drive still answers the
    // refused write.
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    assert_eq!(pc.read(&p102).await.unwrap(), 1000);
}
