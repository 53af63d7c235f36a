use super::*;
use crate::tool::client::{ClientError, DeviceErrorKind};
use crate::tool::fake::{FakeClient, refusal};
use drive_profile::Family;
use serde_json::Value;

const MS: Duration = Duration::from_millis(1);

/// P000 answers 1500 1/min; P130 is refused; index 9999 reads -5.
fn drive(index: u16) -> std::result::Result<i64, ClientError> {
    match index {
        8318 => Ok(1_500_000),
        8470 => Err(refusal(DeviceErrorKind::Refused, "parameter lock")),
        9999 => Ok(-5),
        _ => Err(ClientError::link(
            drive_client::LinkFault::NoAnswer,
            "no answer from drive 1",
        )),
    }
}

fn targets(keys: &[&str]) -> Vec<Target> {
    keys.iter()
        .map(|k| Target::resolve(Family::Movidrive, k, 1000..=0xFFFF).unwrap())
        .collect()
}

async fn run(
    keys: &[&str],
    format: Format,
    count: u64,
    stop: impl Future<Output = ()>,
) -> (Result<u64>, String) {
    let mut client = FakeClient::new(drive);
    let mut text = String::new();
    let options = Options {
        interval: 200 * MS,
        count,
        format,
    };
    let r = watch(
        &mut client,
        &targets(keys),
        options,
        &mut |s| {
            text.push_str(s);
            Ok(())
        },
        stop,
    )
    .await;
    (r, text)
}

#[tokio::test(start_paused = true)]
async fn json_is_one_sample_object_per_poll() {
    let (_, text) = run(&["P000", "9999"], Format::Json, 3, std::future::pending()).await;
    let samples: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(samples.len(), 3);
    assert!(
        samples
            .iter()
            .all(|s| s["type"] == "sample" && s["values"][1]["raw"] == -5)
    );
}

#[tokio::test(start_paused = true)]
async fn csv_has_a_header_and_one_row_per_poll() {
    let (r, text) = run(
        &["P000", "P130", "9999"],
        Format::Csv,
        2,
        std::future::pending(),
    )
    .await;
    // P130 is refused in every poll: shown in its cells, and the watch fails at the end.
    assert!(
        r.unwrap_err()
            .to_string()
            .starts_with("1 of 3 parameter(s) could not be read in any of the 2 poll(s): P130"),
    );
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(
        rows[0],
        "time,P000 Speed [1/min],P130 Ramp t11 up CW [s],index 9999 (raw)"
    );
    assert_eq!(rows.len(), 3);
    let fields: Vec<&str> = rows[1].split(',').collect();
    assert_eq!(&fields[1..], ["1500.000", "", "-5"]);
    assert_eq!(csv_field("a, \"b\""), "\"a, \"\"b\"\"\"");
}

#[tokio::test(start_paused = true)]
async fn stop_ends_an_endless_watch_cleanly() {
    let (r, text) = run(&["P000"], Format::Lines, 0, tokio::time::sleep(700 * MS)).await;
    // Polls at 0, 200, 400 and 600 ms; the stop at 700 ms ends it without an error.
    assert_eq!(r.unwrap(), 4);
    assert_eq!(text.lines().count(), 4);
    assert!(
        text.lines().all(|l| l.ends_with("  P000 1500.000 1/min")),
        "{text}"
    );
}

#[tokio::test(start_paused = true)]
async fn a_link_failure_ends_the_watch_with_an_error() {
    let (r, text) = run(&["P000", "P001"], Format::Lines, 3, std::future::pending()).await;
    let e = r.unwrap_err();
    assert_eq!(e.exit_code(), 1);
    assert!(
        e.to_string()
            .contains("P001: no answer from drive 1; the watch stopped after 0 poll(s)"),
        "{e}"
    );
    assert_eq!(text, "");
}

#[tokio::test(start_paused = true)]
async fn the_table_is_redrawn_in_place() {
    let (r, text) = run(&["P000", "P130"], Format::Table, 2, std::future::pending()).await;
    // P130 is refused in every poll: shown in its cells, and the watch fails at the end.
    assert!(
        r.unwrap_err()
            .to_string()
            .starts_with("1 of 2 parameter(s) could not be read in any of the 2 poll(s): P130"),
    );
    // The second table moves the cursor up over the three lines of the first and clears.
    let (first, second) = text.split_once("\x1b[3F\x1b[J").unwrap();
    assert_eq!(first.lines().count(), 3);
    assert!(
        first.contains("P000 Speed") && first.contains("1500.000 1/min"),
        "{first}"
    );
    assert!(first.contains("refused: parameter lock"), "{first}");
    assert_eq!(second.lines().count(), 3);
}

#[tokio::test(start_paused = true)]
async fn issue18_a_watch_that_read_nothing_fails_naming_what_failed() {
    let (r, text) = run(&["P130"], Format::Lines, 2, std::future::pending()).await;
    let e = r.unwrap_err();
    assert_eq!(e.exit_code(), 1);
    assert_eq!(
        e.to_string(),
        "no parameter could be read in 2 poll(s): P130 (parameter lock)"
    );
    // The refusals were shown as they came.
    assert_eq!(text.lines().count(), 2);
    // One parameter never read beside one read: the others' values are shown, and the
    // watch fails naming the one.
    let (r, _) = run(&["P000", "P130"], Format::Json, 2, std::future::pending()).await;
    assert_eq!(
        r.unwrap_err().to_string(),
        "1 of 2 parameter(s) could not be read in any of the 2 poll(s): P130 (parameter \
         lock); the values of the others are above"
    );
}

#[tokio::test(start_paused = true)]
async fn issue18_csv_headers_are_unique() {
    let (_, text) = run(
        &["P000", "P000", "9999"],
        Format::Csv,
        1,
        std::future::pending(),
    )
    .await;
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(
        header,
        [
            "time",
            "P000 Speed [1/min]",
            "P000 Speed [1/min] (2)",
            "index 9999 (raw)"
        ]
    );
}

#[test]
fn csv_and_json_exclude_each_other() {
    assert_eq!(
        Format::choose(true, true, false).unwrap_err().exit_code(),
        2
    );
    assert_eq!(Format::choose(false, false, true).unwrap(), Format::Table);
    assert_eq!(Format::choose(false, false, false).unwrap(), Format::Lines);
    assert_eq!(Format::choose(true, false, true).unwrap(), Format::Csv);
}
