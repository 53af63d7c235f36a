//! Figures in the gateway's log as a person reads them: to what is meaningful (three
//! significant digits, shares to 0.1 %), never a float's full expansion
//! (`demand=0.06797656140000001`).

use std::time::Duration;

/// `x` to three significant digits, without trailing zeros (`0.0680`, `1.25`, `1500`).
pub fn sig3(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    if x == 0.0 {
        return "0".to_owned();
    }
    let digits = x.abs().log10().floor() as i32;
    let decimals = usize::try_from(2 - digits).unwrap_or(0);
    let text = format!("{x:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        text
    }
}

/// A share (1.0 = 100 %) as a percentage to 0.1 % (`6.8 %`, `128.0 %`).
pub fn percent(x: f64) -> String {
    format!("{:.1} %", x * 100.0)
}

/// A duration to three significant digits in ms below a second, else in s (`150 ms`,
/// `3.44 ms`, `0.5 ms`, `1.5 s`).
pub fn duration(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 1.0 {
        format!("{} ms", sig3(s * 1e3))
    } else {
        format!("{} s", sig3(s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_rounded_to_what_is_meaningful() {
        assert_eq!(sig3(0.067_976_561_400_000_01), "0.068");
        assert_eq!(sig3(1.254_9), "1.25");
        assert_eq!(sig3(1500.4), "1500");
        assert_eq!(sig3(0.0), "0");
        assert_eq!(sig3(-0.123_456), "-0.123");
        assert_eq!(percent(0.067_976_561_400_000_01), "6.8 %");
        assert_eq!(percent(1.28), "128.0 %");
        assert_eq!(duration(Duration::from_millis(150)), "150 ms");
        assert_eq!(duration(Duration::from_micros(3440)), "3.44 ms");
        assert_eq!(duration(Duration::from_millis(100)), "100 ms");
        assert_eq!(duration(Duration::from_millis(1500)), "1.5 s");
        assert_eq!(duration(Duration::from_secs(5)), "5 s");
    }
}
