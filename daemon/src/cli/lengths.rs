//! Lengths and speeds a person types on the console verbs: millimetres (`--x-mm 12.5`), and
//! the deprecated metre flags (`--x-m 0.0125`) that scripts still use. Both become a
//! [`Metres`] for the wire protocol, which stays SI.
//!
//! Hand-written because the conversion must be exact: a millimetre value is read as the
//! decimal it is, shifted by three places (`12.5` mm is parsed as `12.5e-3`), so that the
//! same position typed in mm or in m sends bit-for-bit the same request. Dividing the
//! parsed float by 1000 would round twice and could differ in the last bit.

use std::fmt;

/// A length or speed in SI units (metres, metres per second), from either form of a flag.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metres(pub f64);

/// The farthest a typed position or step can be from the origin, m. A guard against a
/// slip (a millimetre value given to a metre flag); the daemon applies its own, tighter
/// limits (workspace, `operation.max_jog_m`, `control.motion.max_speed_m_s`).
pub const MAX_LENGTH_M: f64 = 1.0;
/// The fastest speed the command line passes on, m/s (the same kind of guard).
pub const MAX_SPEED_M_S: f64 = 1.0;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Unit {
    Mm,
    M,
}

impl Unit {
    fn name(self) -> &'static str {
        match self {
            Unit::Mm => "mm",
            Unit::M => "m",
        }
    }

    /// `max` (in SI) in this unit.
    fn show(self, max_si: f64) -> String {
        match self {
            Unit::Mm => format!("{}", max_si * 1000.0),
            Unit::M => format!("{max_si}"),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// A signed position or step.
    Position,
    /// A strictly positive length (a track length).
    Distance,
    /// A strictly positive speed.
    Speed,
}

#[derive(Debug, PartialEq)]
struct BadValue(String);

impl fmt::Display for BadValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The decimal in `text` (in `unit`) as SI, checked for `kind`.
fn parse(text: &str, unit: Unit, kind: Kind) -> Result<Metres, BadValue> {
    let t = text.trim();
    let typed: f64 = t
        .parse()
        .map_err(|_| BadValue(format!("{t:?} is not a number")))?;
    if !typed.is_finite() {
        return Err(BadValue(format!("{t} is not a finite number")));
    }
    let si = match unit {
        Unit::M => typed,
        Unit::Mm => shifted_by_thousand(t).unwrap_or(typed / 1000.0),
    };
    let (max, what) = match kind {
        Kind::Position | Kind::Distance => (MAX_LENGTH_M, ""),
        Kind::Speed => (MAX_SPEED_M_S, "/s"),
    };
    let u = unit.name();
    if kind != Kind::Position && si <= 0.0 {
        return Err(BadValue(format!("{t} {u}{what} must be greater than 0")));
    }
    if si.abs() > max {
        let hint = match unit {
            Unit::M => format!(" (this deprecated flag takes metres; for {t} mm use the -mm flag)"),
            Unit::Mm => String::new(),
        };
        return Err(BadValue(format!(
            "{t} {u}{what} is beyond anything the arm can do (at most {} {u}{what}){hint}",
            unit.show(max)
        )));
    }
    Ok(Metres(si))
}

/// The decimal `t` divided by 1000 exactly, then rounded once: the exponent moved by 3.
fn shifted_by_thousand(t: &str) -> Option<f64> {
    let (mantissa, exp) = match t.find(['e', 'E']) {
        Some(i) => (&t[..i], t[i + 1..].parse::<i32>().ok()?),
        None => (t, 0),
    };
    format!("{mantissa}e{}", exp.checked_sub(3)?).parse().ok()
}

/// `--x-mm`, `--dz-mm`, ...: a signed position or step in millimetres.
pub fn position_mm(text: &str) -> Result<Metres, String> {
    parse(text, Unit::Mm, Kind::Position).map_err(|e| e.0)
}

/// The deprecated `--x-m`, `--dz-m`, ...: a signed position or step in metres.
pub fn position_m(text: &str) -> Result<Metres, String> {
    parse(text, Unit::M, Kind::Position).map_err(|e| e.0)
}

/// `--length-mm`: a positive length in millimetres.
pub fn distance_mm(text: &str) -> Result<Metres, String> {
    parse(text, Unit::Mm, Kind::Distance).map_err(|e| e.0)
}

/// The deprecated `--length-m`.
pub fn distance_m(text: &str) -> Result<Metres, String> {
    parse(text, Unit::M, Kind::Distance).map_err(|e| e.0)
}

/// `--speed-mm-s`: a positive speed in millimetres per second.
pub fn speed_mm_s(text: &str) -> Result<Metres, String> {
    parse(text, Unit::Mm, Kind::Speed).map_err(|e| e.0)
}

/// The deprecated `--speed-m-s`.
pub fn speed_m_s(text: &str) -> Result<Metres, String> {
    parse(text, Unit::M, Kind::Speed).map_err(|e| e.0)
}

/// The value of whichever form was given (clap refuses both at once), in SI.
pub fn either(mm: Option<Metres>, m: Option<Metres>) -> Option<f64> {
    mm.or(m).map(|v| v.0)
}

/// Metres from `N` comma-separated millimetre numbers (`x0,z0,x1,z1`, `x,z`), each named in
/// the error with its `flag`.
pub fn mm_tuple<const N: usize>(flag: &str, names: [&str; N], s: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != N {
        let count = ["no", "one", "two", "three", "four", "five", "six"]
            .get(N)
            .map_or_else(|| N.to_string(), |w| (*w).to_string());
        return Err(format!(
            "{flag} {s:?}: give {count} numbers in mm, {} (got {})",
            names.join(","),
            parts.len()
        ));
    }
    let mut out = [0.0; N];
    for (i, (p, name)) in parts.iter().zip(names).enumerate() {
        let v: f64 = p
            .parse()
            .map_err(|_| format!("{flag}: {name} = {p:?} is not a number (mm)"))?;
        if !v.is_finite() {
            return Err(format!("{flag}: {name} = {p:?} is not a finite number"));
        }
        out[i] = v * 1e-3;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn millimetres_are_the_same_decimal_in_metres() {
        for (mm, m) in [
            ("12", "0.012"),
            ("-2", "-0.002"),
            ("0.1", "0.0001"),
            ("12.5", "0.0125"),
            ("1e1", "0.01"),
            ("3.3E-1", "0.00033"),
            ("0", "0"),
        ] {
            assert_eq!(position_mm(mm), position_m(m), "{mm} mm against {m} m");
        }
    }

    #[test]
    fn non_finite_and_absurd_values_are_refused_with_the_reason() {
        for bad in ["nan", "NaN", "inf", "-inf", "infinity"] {
            let e = position_mm(bad).expect_err(bad);
            assert!(e.contains("not a finite number"), "{bad}: {e}");
        }
        let e = position_mm("twelve").expect_err("words");
        assert!(e.contains("not a number"), "{e}");
        let e = position_mm("1000.5").expect_err("past a metre");
        assert!(e.contains("at most 1000 mm"), "{e}");
        assert!(position_mm("-1000").is_ok());
        // The slip the guard is for: millimetres given to a metre flag.
        let e = position_m("12").expect_err("12 m");
        assert!(
            e.contains("at most 1 m") && e.contains("for 12 mm use the -mm flag"),
            "{e}"
        );
        let e = speed_mm_s("0").expect_err("zero speed");
        assert!(e.contains("greater than 0"), "{e}");
        let e = speed_m_s("-0.01").expect_err("negative speed");
        assert!(e.contains("greater than 0"), "{e}");
        let e = speed_mm_s("5000").expect_err("5 m/s");
        assert!(e.contains("at most 1000 mm/s"), "{e}");
        let e = distance_mm("-3").expect_err("negative length");
        assert!(e.contains("greater than 0"), "{e}");
        assert_eq!(distance_mm("150"), distance_m("0.15"));
        let e = position_mm("1e400").expect_err("overflow");
        assert!(e.contains("not a finite number"), "{e}");
    }

    proptest! {
        /// Any decimal of millimetres equals the same digits with the point moved three
        /// places and read as metres, bit for bit.
        #[test]
        fn any_decimal_shifts_exactly(int in 0u32..1000, frac in 0u32..1_000_000, neg: bool) {
            let sign = if neg { "-" } else { "" };
            let mm = format!("{sign}{int}.{frac:06}");
            let m = format!("{sign}0.{int:03}{frac:06}");
            prop_assert_eq!(position_mm(&mm), position_m(&m));
        }
    }
}
