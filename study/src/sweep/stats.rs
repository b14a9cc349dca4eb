//! Summary statistics of score samples.

use serde::{Deserialize, Serialize};

/// Mean, standard deviation (n - 1), median with its Monte Carlo standard
/// error, and 5th/95th percentiles (linear interpolation between order
/// statistics) of the finite values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Finite values the statistics are computed from.
    pub n: usize,
    /// Arithmetic mean (`None` when `n = 0`).
    pub mean: Option<f64>,
    /// Sample standard deviation with `n - 1` (`None` when `n < 2`).
    pub std: Option<f64>,
    /// Median (`None` when `n = 0`).
    pub median: Option<f64>,
    /// Monte Carlo standard error of the median: the distribution-free 95 %
    /// confidence interval of the median from two order statistics, divided
    /// by `2 x 1.96` (see [`median_standard_error`]); `None` below
    /// [`MEDIAN_SE_MIN_N`] values. Summaries written before it was added
    /// read as `None`.
    #[serde(default)]
    pub median_se: Option<f64>,
    /// 5th percentile (`None` when `n = 0`).
    pub p5: Option<f64>,
    /// 95th percentile (`None` when `n = 0`).
    pub p95: Option<f64>,
}

impl Stats {
    /// Statistics of `values` (non-finite values are ignored; `n` counts
    /// the finite ones). Values are summed in the given order, so equal
    /// inputs give bit-identical statistics.
    pub fn of(values: &[f64]) -> Stats {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        let n = v.len();
        if n == 0 {
            return Stats {
                n,
                mean: None,
                std: None,
                median: None,
                median_se: None,
                p5: None,
                p95: None,
            };
        }
        let mean = v.iter().sum::<f64>() / n as f64;
        let std = (n > 1)
            .then(|| (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt());
        v.sort_by(f64::total_cmp);
        Stats {
            n,
            mean: Some(mean),
            std,
            median: Some(quantile(&v, 0.5)),
            median_se: median_standard_error(&v),
            p5: Some(quantile(&v, 0.05)),
            p95: Some(quantile(&v, 0.95)),
        }
    }
}

/// Fewest values [`median_standard_error`] gives an error for: at 8 the
/// interval spans the middle 69 % of the values, below that it runs into
/// the extremes.
pub const MEDIAN_SE_MIN_N: usize = 8;

/// Monte Carlo standard error of the median of `sorted` (ascending, finite):
/// `(q(1/2 + 0.98/sqrt(n)) - q(1/2 - 0.98/sqrt(n))) / (2 x 1.96)` with `q`
/// the sample quantile ([`quantile`]). The fraction of values below the
/// median is a binomial proportion with standard deviation `1/(2 sqrt(n))`,
/// so those quantiles bound a distribution-free 95 % confidence interval of
/// the median, and its width over `2 x 1.96` is the standard error a normal
/// interval of that width would have: asymptotically `1 / (2 f(median)
/// sqrt(n))` whatever the distribution, `sqrt(pi/2) sigma / sqrt(n)` for
/// normal values (tested). Interpolated quantiles, not whole order
/// statistics: rounding the ranks outward overstated it by 9 % at 100 values
/// (measured). `None` for fewer than [`MEDIAN_SE_MIN_N`] values.
pub fn median_standard_error(sorted: &[f64]) -> Option<f64> {
    let n = sorted.len();
    if n < MEDIAN_SE_MIN_N {
        return None;
    }
    let half = 0.98 / (n as f64).sqrt();
    Some((quantile(sorted, 0.5 + half) - quantile(sorted, 0.5 - half)) / (2.0 * 1.96))
}

/// Root mean square of the finite values of `values` and its Monte Carlo
/// standard error (delta method: the mean square's standard error is the
/// sample standard deviation of the squares over `sqrt(n)`, and the root
/// halves the relative error): `(rms, se)`. `None` for fewer than two finite
/// values or an RMS of zero.
pub fn rms_with_error(values: &[f64]) -> Option<(f64, f64)> {
    let sq: Vec<f64> = values
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x * x)
        .collect();
    let n = sq.len();
    if n < 2 {
        return None;
    }
    let ms = sq.iter().sum::<f64>() / n as f64;
    if ms <= 0.0 || !ms.is_finite() {
        return None;
    }
    let var = sq.iter().map(|s| (s - ms).powi(2)).sum::<f64>() / (n - 1) as f64;
    let rms = ms.sqrt();
    Some((rms, rms * (var.sqrt() / (n as f64).sqrt()) / (2.0 * ms)))
}

/// Quantile `q` of sorted values by linear interpolation between order
/// statistics at position `q (n - 1)` (the common "type 7" definition).
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_a_known_sample() {
        // 1..=20: mean 10.5, sample std sqrt(35), median 10.5,
        // p5 at position 0.95 -> 1.95, p95 at 18.05 -> 19.05.
        let v: Vec<f64> = (1..=20).rev().map(f64::from).collect();
        let s = Stats::of(&v);
        assert_eq!(s.n, 20);
        assert_eq!(s.mean, Some(10.5));
        assert!((s.std.unwrap() - 35f64.sqrt()).abs() < 1e-12);
        assert_eq!(s.median, Some(10.5));
        assert!((s.p5.unwrap() - 1.95).abs() < 1e-12);
        assert!((s.p95.unwrap() - 19.05).abs() < 1e-12);
    }

    /// Mean of the estimated standard errors and standard deviation of the
    /// estimates over `reps` seeded samples of `n` normal values.
    fn calibration(
        n: usize,
        reps: usize,
        estimate: impl Fn(&[f64]) -> Option<(f64, f64)>,
    ) -> (f64, f64) {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(20261127);
        let (mut values, mut errors) = (Vec::new(), Vec::new());
        for _ in 0..reps {
            let x: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
            let (v, e) = estimate(&x).expect("enough values");
            values.push(v);
            errors.push(e);
        }
        let s = Stats::of(&values);
        (Stats::of(&errors).mean.unwrap(), s.std.unwrap())
    }

    #[test]
    fn median_standard_error_matches_the_spread_of_medians() {
        // Normal samples of 100: the median's standard deviation is
        // sqrt(pi/2)/sqrt(100) = 0.1253 asymptotically. Over 4000
        // replications the spread of the medians is known to 1/sqrt(2 x 4000)
        // = 1.1 % (one standard error); the estimated standard error's mean
        // is close to it (measured: 0.1250 against a spread of 0.1241 and
        // the asymptotic 0.1253). 5 %: four standard errors of the spread
        // and the small-sample difference.
        let (se, spread) = calibration(100, 4000, |x| {
            let s = Stats::of(x);
            Some((s.median?, s.median_se?))
        });
        let theory = (std::f64::consts::PI / 2.0).sqrt() / 10.0;
        assert!((se / spread - 1.0).abs() < 0.05, "{se} vs {spread}");
        assert!((spread / theory - 1.0).abs() < 0.05, "{spread} vs {theory}");
        // Too few values for the interval.
        assert_eq!(Stats::of(&[1.0; 7]).median_se, None);
        assert!(Stats::of(&[1.0; 8]).median_se.is_some());
    }

    #[test]
    fn rms_standard_error_matches_the_spread_of_rms() {
        // Normal samples of 50: the RMS's standard deviation is about
        // 1/sqrt(2 x 50) = 0.1. The delta-method error is estimated from the
        // sample's own fourth moment, which it underestimates a little at 50
        // values (measured: 0.0970 against a spread of 0.1007, 3.6 % low).
        // 6 %: that bias and two standard errors (1.1 % each) of the spread
        // over 4000 replications.
        let (se, spread) = calibration(50, 4000, rms_with_error);
        assert!((se / spread - 1.0).abs() < 0.06, "{se} vs {spread}");
        assert!((spread / 0.1 - 1.0).abs() < 0.05, "{spread}");
        assert_eq!(rms_with_error(&[1.0]), None);
        assert_eq!(rms_with_error(&[0.0, 0.0]), None);
        let (rms, se) = rms_with_error(&[3.0, 4.0, f64::NAN]).unwrap();
        // sqrt((9 + 16)/2); squares 9 and 16: sd 4.95, over sqrt(2) 3.5, over
        // 2 x 12.5 and times the RMS.
        assert!((rms - 12.5f64.sqrt()).abs() < 1e-15);
        let want = 12.5f64.sqrt() * (24.5f64.sqrt() / 2f64.sqrt()) / 25.0;
        assert!((se - want).abs() < 1e-15, "{se} vs {want}");
    }

    #[test]
    fn empty_and_non_finite() {
        let s = Stats::of(&[f64::NAN]);
        assert_eq!(s.n, 0);
        assert_eq!(s.mean, None);
        let s = Stats::of(&[2.0, f64::INFINITY]);
        assert_eq!((s.n, s.mean, s.std), (1, Some(2.0), None));
    }
}
