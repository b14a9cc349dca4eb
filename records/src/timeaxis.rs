//! Checking that a stored time axis (CSV time column, uneven UFF abscissa)
//! is a uniform sampling grid, and recovering its interval.
//!
//! # Tolerance
//!
//! A time value in a text file carries two kinds of error:
//!
//! * **printing**: it was rounded to the digits the writer printed. The
//!   printing style is estimated from the whole column: a fixed number of
//!   decimals (`%.6f`: the unit is `10^-D`), a fixed number of significant
//!   digits (`%g`, `E13.5`: the unit scales with the magnitude), or the
//!   shortest round-trip form (very many digits). With `D` the most
//!   decimals and `S` the most significant digits seen anywhere in the
//!   column, a value `t` is known to within half a unit of
//!   `max(10^-D, 10^(floor(log10|t|) - S + 1))`. Using the *most* digits
//!   seen matters: writers drop trailing zeros ("0.5"), and such a value is
//!   exact, not coarse.
//! * **arithmetic**: writers compute `t` as `t0 + i*dt` or by repeated
//!   `t += dt` in double precision. The first costs a few ulps of `t`, the
//!   second drifts by up to about `n^2 eps dt / 2`, below `1e-4 dt` for
//!   records shorter than about a million samples.
//!
//! Each step `t[i] - t[i-1]` must equal the median step within the printing
//! error of both steps' values, a few ulps, and a floor of `1e-4 dt` (`dt`
//! the mean interval from the end points). The median, not `dt`, so that a
//! missing or doubled sample is named where it is: it moves `dt` by
//! `dt / (n - 1)`, more than the printing error of a column printed to the
//! last bit, and every step would differ from it. Each value
//! must lie on the grid `t0 + i dt` within its own, the first and the last
//! value's printing error, a few ulps and the same floor (this catches slow
//! drift that no single step shows).
//!
//! Both tolerances are capped at `0.45 dt`. A missing or doubled sample
//! changes one step by a whole `dt` and moves the grid position of every
//! later value by at least `dt / 2` against the end-point fit, so with the
//! cap such damage is always detected, however coarsely the column is
//! printed. The price: a column printed with a unit close to `dt` but not
//! dividing it (e.g. three decimals at 900 Hz) is refused; the message says
//! so, and such a file can be read without its time column by passing the
//! sampling rate.

use crate::numfmt::Printed;

/// Sampling intervals (s) at and above which a time axis whose unit the file
/// does not state is refused rather than taken as seconds.
///
/// Structural tests sample at tens of hertz to kilohertz: building models
/// have their modes at 0.5-100 Hz, full-scale buildings at 0.1-10 Hz, and
/// a record sees a mode only below half its sampling rate (analyzers
/// sample at 2.56 times their band). An interval of 1 s (1 Hz sampling,
/// Nyquist 0.5 Hz) sees none of a model's modes and hardly any building's.
/// Times written in milliseconds and read as seconds give exactly such
/// intervals, 1000 times too large, for every true rate up to 1 kHz (at
/// 64 Hz: 15.625 "s"), and every M, K and damping identified from them is
/// wrong by orders of magnitude with no other symptom. Not lower: records
/// at 1-10 kHz written in milliseconds read as 0.1-1 s, which this misses,
/// but 1-10 Hz sampling is a real choice (ambient tests of tall buildings,
/// decimated records), and refusing those would refuse good files.
/// Declaring the unit (`time [s]`, `time_ms`, a UFF abscissa label) or
/// passing the sampling rate lifts the refusal.
pub(crate) const UNDECLARED_UNIT_MAX_DT_S: f64 = 1.0;

/// Fraction of `dt` always tolerated (double-precision accumulation).
const FLOOR: f64 = 1e-4;
/// Fraction of `dt` never exceeded (see the module documentation).
const CAP: f64 = 0.45;

/// How finely the values of a column were printed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PrintModel {
    max_decimals: i32,
    max_significant: u32,
    exact: bool,
}

impl PrintModel {
    /// Values stored in binary: no printing error.
    pub fn exact() -> Self {
        PrintModel {
            max_decimals: 0,
            max_significant: 0,
            exact: true,
        }
    }

    /// Nothing observed yet; feed it every printed value with [`observe`].
    pub fn printed() -> Self {
        PrintModel {
            max_decimals: i32::MIN,
            max_significant: 0,
            exact: false,
        }
    }

    pub fn observe(&mut self, p: Printed) {
        self.max_decimals = self.max_decimals.max(p.decimals);
        self.max_significant = self.max_significant.max(p.significant);
    }

    /// Half a unit of the last printed digit of a value `v` of the column,
    /// multiplied by `scale` (unit conversion applied to the values).
    pub fn half_unit(&self, v: f64, scale: f64) -> f64 {
        if self.exact {
            return 0.0;
        }
        let by_decimals = if self.max_decimals == i32::MIN {
            f64::INFINITY
        } else {
            0.5 * 10f64.powi(-self.max_decimals.clamp(-400, 400))
        };
        // `v` is already scaled; the digits were printed for `v / scale`.
        let printed = (v / scale).abs();
        let by_significant = if printed > 0.0 && printed.is_finite() && self.max_significant > 0 {
            let mag = printed.log10().floor() as i32;
            0.5 * 10f64.powi((mag - self.max_significant as i32 + 1).clamp(-400, 400))
        } else {
            0.0
        };
        by_decimals.max(by_significant) * scale
    }
}

/// [`PrintModel::half_unit`] of the values of one column, without a
/// logarithm per value: the decade of the last value is remembered, and a
/// value well inside it (by a relative 1e-12, far beyond the error of
/// `log10`) has the same `floor(log10)` and so the same half unit. The
/// results are bit for bit those of `half_unit`.
pub(crate) struct HalfUnits {
    model: PrintModel,
    scale: f64,
    by_decimals: f64,
    /// `(low, high, by_significant)`: printed values in `[low, high)` have
    /// the half unit `by_significant` by significant digits.
    decade: (f64, f64, f64),
}

impl HalfUnits {
    /// Half units of values scaled by `scale` (see [`PrintModel::half_unit`]).
    pub fn new(model: &PrintModel, scale: f64) -> Self {
        let by_decimals = if model.max_decimals == i32::MIN {
            f64::INFINITY
        } else {
            0.5 * 10f64.powi(-model.max_decimals.clamp(-400, 400))
        };
        Self {
            model: *model,
            scale,
            by_decimals,
            decade: (f64::NAN, f64::NAN, 0.0),
        }
    }

    /// The same as `model.half_unit(v, scale)`.
    pub fn of(&mut self, v: f64) -> f64 {
        if self.model.exact {
            return 0.0;
        }
        let printed = (v / self.scale).abs();
        let by_significant =
            if printed > 0.0 && printed.is_finite() && self.model.max_significant > 0 {
                let (low, high, cached) = self.decade;
                if printed >= low && printed < high {
                    cached
                } else {
                    let mag = printed.log10().floor() as i32;
                    let q = 0.5
                        * 10f64
                            .powi((mag - self.model.max_significant as i32 + 1).clamp(-400, 400));
                    // Far from subnormal and overflowing powers of ten, where
                    // 10^mag is accurate to a few ulps.
                    if (-300..=300).contains(&mag) {
                        let base = 10f64.powi(mag);
                        self.decade = (base * (1.0 + 1e-12), 10.0 * base * (1.0 - 1e-12), q);
                    }
                    q
                }
            } else {
                0.0
            };
        self.by_decimals.max(by_significant) * self.scale
    }
}

/// Why a time axis was refused; `index` is the sample concerned.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum AxisError {
    NotIncreasing {
        index: usize,
        previous: f64,
        value: f64,
    },
    Step {
        index: usize,
        step: f64,
        dt: f64,
        tolerance: f64,
    },
    OffGrid {
        index: usize,
        value: f64,
        expected: f64,
        dt: f64,
        tolerance: f64,
    },
    Overflow {
        index: usize,
    },
}

/// Checks `t` (at least two values) and returns the sampling interval.
///
/// `scale` is the factor already applied to the printed values (1e-3 for a
/// column in milliseconds).
pub(crate) fn check_uniform(t: &[f64], model: &PrintModel, scale: f64) -> Result<f64, AxisError> {
    let n = t.len();
    debug_assert!(n >= 2);
    for i in 1..n {
        if t[i] <= t[i - 1] {
            return Err(AxisError::NotIncreasing {
                index: i,
                previous: t[i - 1],
                value: t[i],
            });
        }
    }
    let (t0, tn) = (t[0], t[n - 1]);
    let span = tn - t0;
    let dt = span / (n - 1) as f64;
    if !span.is_finite() || dt <= 0.0 || dt.is_nan() {
        return Err(AxisError::Overflow { index: n - 1 });
    }
    let (q0, qn) = (
        model.half_unit(t[0], scale),
        model.half_unit(t[n - 1], scale),
    );
    let mut half_units = HalfUnits::new(model, scale);
    let mut q = |i: usize| half_units.of(t[i]);
    let eps = f64::EPSILON;
    let clamp = |tol: f64| tol.max(FLOOR * dt).min(CAP * dt);

    // Steps: catches a gap or a doubled sample at the line where it is. The
    // reference is the median step (a gap or a doubled sample does not move
    // it), known to within its own values' printing error and ulps.
    let reference = {
        let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        *steps.select_nth_unstable_by((n - 1) / 2, f64::total_cmp).1
    };
    // The step's place, for its values' printing error.
    let reference_at = (1..n)
        .find(|&i| t[i] - t[i - 1] == reference)
        .expect("the median is one of the steps");
    let reference_error = model.half_unit(t[reference_at], scale)
        + model.half_unit(t[reference_at - 1], scale)
        + 4.0 * eps * (t[reference_at].abs() + t[reference_at - 1].abs());
    let mut q_previous = q0;
    for i in 1..n {
        let step = t[i] - t[i - 1];
        let qi = q(i);
        let tol =
            clamp(qi + q_previous + reference_error + 4.0 * eps * (t[i].abs() + t[i - 1].abs()));
        q_previous = qi;
        if (step - reference).abs() > tol {
            return Err(AxisError::Step {
                index: i,
                step,
                dt: reference,
                tolerance: tol,
            });
        }
    }
    // Positions: catches drift.
    let scale_abs = t0.abs().max(tn.abs());
    for (i, &ti) in t.iter().enumerate() {
        let expected = t0 + i as f64 * dt;
        let tol = clamp(q(i) + q0.max(qn) + 8.0 * eps * scale_abs);
        if (ti - expected).abs() > tol {
            return Err(AxisError::OffGrid {
                index: i,
                value: ti,
                expected,
                dt,
                tolerance: tol,
            });
        }
    }
    Ok(regenerating_interval(t, dt))
}

/// The end-point interval is the best estimate, but rarely the exact double
/// a writer used. If some double within a few ulps of it (or of the first
/// step) regenerates every stored time bit for bit as `t0 + i * dt` — the
/// way frameid's writer computes them — return that one, so that a record
/// written and read back has the identical interval.
fn regenerating_interval(t: &[f64], estimate: f64) -> f64 {
    let n = t.len();
    let t0 = t[0];
    let regenerates = |c: f64| {
        t0 + c == t[1]
            && t0 + (n - 1) as f64 * c == t[n - 1]
            && t.iter().enumerate().all(|(i, &ti)| t0 + i as f64 * c == ti)
    };
    for base in [estimate, t[1] - t0] {
        let mut lo = base;
        let mut hi = base;
        if regenerates(base) {
            return base;
        }
        for _ in 0..4 {
            lo = next_down(lo);
            hi = next_up(hi);
            if regenerates(lo) {
                return lo;
            }
            if regenerates(hi) {
                return hi;
            }
        }
    }
    estimate
}

/// The next larger double (for positive finite `x`).
fn next_up(x: f64) -> f64 {
    f64::from_bits(x.to_bits() + 1)
}

/// The next smaller double (for positive finite `x`).
fn next_down(x: f64) -> f64 {
    if x > 0.0 {
        f64::from_bits(x.to_bits() - 1)
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numfmt::printed_precision;

    fn model_of(texts: &[&str]) -> (Vec<f64>, PrintModel) {
        let mut m = PrintModel::printed();
        let t = texts
            .iter()
            .map(|s| {
                m.observe(printed_precision(s));
                s.parse().unwrap()
            })
            .collect();
        (t, m)
    }

    #[test]
    fn remembered_decades_give_the_same_half_units() {
        let mut values = vec![0.0, -0.0, 1e-310, 5e-324, 1e300, 1.7e308, f64::NAN, -3.5];
        for k in -310..=308 {
            let p = format!("1e{k}").parse::<f64>().unwrap();
            for v in [
                p,
                next_up(p),
                next_down(p),
                0.999_999_999_999_9 * p,
                9.999 * p,
            ] {
                values.push(v);
            }
        }
        let mut x = 0.123_f64;
        for _ in 0..20_000 {
            // A deterministic spread over many decades, and runs within one.
            x = (x * 7919.0 + 0.61).fract();
            values.push(10f64.powf(40.0 * x - 20.0));
            values.push(1000.0 + x);
        }
        for texts in [
            &["0.000488"][..],
            &["4.88281E-04", "1.5"],
            &["12345678901234567"],
            &[],
        ] {
            let mut model = PrintModel::printed();
            for s in texts {
                model.observe(printed_precision(s));
            }
            for scale in [1.0, 1e-3] {
                let mut cached = HalfUnits::new(&model, scale);
                for &v in values.iter().chain(values.iter().rev()) {
                    let want = model.half_unit(v, scale);
                    assert_eq!(cached.of(v).to_bits(), want.to_bits(), "{v:e} {texts:?}");
                }
            }
        }
    }

    #[test]
    fn exact_multiples_printed_coarsely_pass() {
        let (t, m) = model_of(&["0", "0.001", "0.002", "0.003", "0.004"]);
        assert!((check_uniform(&t, &m, 1.0).unwrap() - 0.001).abs() < 1e-15);
    }

    #[test]
    fn rounded_values_pass() {
        // 4096 Hz printed with 6 decimals.
        let texts: Vec<String> = (0..5000)
            .map(|i| format!("{:.6}", i as f64 / 4096.0))
            .collect();
        let refs: Vec<&str> = texts.iter().map(|s| s.as_str()).collect();
        let (t, m) = model_of(&refs);
        let dt = check_uniform(&t, &m, 1.0).unwrap();
        assert!((dt - 1.0 / 4096.0).abs() < 1e-9);
        // %g with 6 significant digits.
        let texts: Vec<String> = (0..5000)
            .map(|i| format!("{:.5e}", 0.5 + i as f64 / 2048.0))
            .collect();
        let refs: Vec<&str> = texts.iter().map(|s| s.as_str()).collect();
        let (t, m) = model_of(&refs);
        assert!(check_uniform(&t, &m, 1.0).is_ok());
    }

    #[test]
    fn missing_sample_is_found_where_it_is() {
        let mut texts: Vec<String> = (0..100)
            .map(|i| format!("{:.3}", i as f64 * 0.001))
            .collect();
        texts.remove(70);
        let refs: Vec<&str> = texts.iter().map(|s| s.as_str()).collect();
        let (t, m) = model_of(&refs);
        match check_uniform(&t, &m, 1.0) {
            Err(AxisError::Step { index, .. }) => assert_eq!(index, 70),
            other => panic!("{other:?}"),
        }
    }

    /// A missing or doubled sample in a column printed to the last bit
    /// (frameid's own form, the shortest text that reads back) is named at
    /// the step where it is. The steps were compared with the end-point
    /// interval, which the gap itself moves by dt / (n - 1): more than the
    /// tolerance of exactly printed values, so the first step was refused
    /// (line 3 of a 2048-row file with a gap at line 502).
    #[test]
    fn gap_in_an_exactly_printed_column_is_found_where_it_is() {
        let dt = 1.0 / 64.0;
        let column = |skip: usize, double: usize| {
            let mut t: Vec<f64> = (0..2048)
                .filter(|&i| i != skip)
                .map(|i| i as f64 * dt)
                .collect();
            if double < t.len() {
                t.insert(double, t[double]);
                t[double + 1] += 0.5 * dt;
            }
            let texts: Vec<String> = t.iter().map(|&v| crate::numfmt::shortest(v)).collect();
            let refs: Vec<&str> = texts.iter().map(|s| s.as_str()).collect();
            model_of(&refs)
        };
        let (t, m) = column(500, usize::MAX);
        match check_uniform(&t, &m, 1.0) {
            Err(AxisError::Step {
                index,
                step,
                dt: reference,
                ..
            }) => {
                assert_eq!((index, step, reference), (500, 2.0 * dt, dt));
            }
            other => panic!("{other:?}"),
        }
        // A sample half way between two others: the first short step.
        let (t, m) = column(usize::MAX, 1500);
        match check_uniform(&t, &m, 1.0) {
            Err(AxisError::Step { index, step, .. }) => assert_eq!((index, step), (1501, 0.5 * dt)),
            other => panic!("{other:?}"),
        }
        // Intact, the interval is exact.
        let (t, m) = column(usize::MAX, usize::MAX);
        assert_eq!(check_uniform(&t, &m, 1.0), Ok(dt));
    }

    #[test]
    fn drift_is_found() {
        // 2 % rate change half way, printed with 4 decimals: no single step
        // shows it, the positions do.
        let mut t = vec![0.0];
        for i in 1..1000 {
            let dt = if i < 500 { 1e-3 } else { 1.02e-3 };
            t.push(t[i - 1] + dt);
        }
        let texts: Vec<String> = t.iter().map(|v| format!("{v:.4}")).collect();
        let refs: Vec<&str> = texts.iter().map(|s| s.as_str()).collect();
        let (t, m) = model_of(&refs);
        assert!(matches!(
            check_uniform(&t, &m, 1.0),
            Err(AxisError::OffGrid { .. })
        ));
    }

    #[test]
    fn repeated_and_decreasing() {
        let (t, m) = model_of(&["0", "0.1", "0.1"]);
        assert!(matches!(
            check_uniform(&t, &m, 1.0),
            Err(AxisError::NotIncreasing { index: 2, .. })
        ));
        let (t, m) = model_of(&["0", "0.1", "0.05"]);
        assert!(matches!(
            check_uniform(&t, &m, 1.0),
            Err(AxisError::NotIncreasing { index: 2, .. })
        ));
    }

    #[test]
    fn regenerated_interval_is_bit_exact() {
        for (t0, dt) in [
            (0.0, 1.0 / 2048.0),
            (0.0, 1e-3),
            (0.0, 1.0 / 3.0e3),
            (0.125, 1e-3),
            (-0.37, 1.0 / 3.0e3),
        ] {
            let t: Vec<f64> = (0..777).map(|i| t0 + i as f64 * dt).collect();
            let got = check_uniform(&t, &PrintModel::exact(), 1.0).unwrap();
            assert_eq!(got.to_bits(), dt.to_bits(), "t0 {t0} dt {dt}");
        }
    }

    #[test]
    fn large_offset_loses_low_bits_of_dt() {
        // With t0 = 1e4 the stored times no longer determine the last bits
        // of dt: many doubles regenerate them. The estimate is still close.
        let (t0, dt) = (1e4, 1e-4);
        let t: Vec<f64> = (0..777).map(|i| t0 + i as f64 * dt).collect();
        let got = check_uniform(&t, &PrintModel::exact(), 1.0).unwrap();
        assert!((got - dt).abs() < 1e-8 * dt);
    }
}
