//! Summary statistics of score samples.

use serde::{Deserialize, Serialize};

/// Mean, standard deviation (n - 1), median and 5th/95th percentiles
/// (linear interpolation between order statistics) of the finite values.
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
            p5: Some(quantile(&v, 0.05)),
            p95: Some(quantile(&v, 0.95)),
        }
    }
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

    #[test]
    fn empty_and_non_finite() {
        let s = Stats::of(&[f64::NAN]);
        assert_eq!(s.n, 0);
        assert_eq!(s.mean, None);
        let s = Stats::of(&[2.0, f64::INFINITY]);
        assert_eq!((s.n, s.mean, s.std), (1, Some(2.0), None));
    }
}
