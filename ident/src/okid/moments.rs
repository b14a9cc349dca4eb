//! Lagged products of the records: the normal equations of the OKID regression.
//!
//! Every entry of the Gram matrix `[X | Y]^T [X | Y]` of the stacked regression is a sum
//! over samples of a product of two channels at two lags. For one record it is the full
//! cross-correlation of the two channels at the lag difference, minus the few products
//! that the zero-initial-condition form leaves out at the record's start (leads) and end
//! (the last `q + lag` samples). The correlations are computed once per record by FFT
//! (cross-spectra accumulated over blocks of samples, so that long records need neither
//! copies nor one huge transform), and summed over the records; a leave-one-record-out
//! Gram matrix is the sum minus that record's contribution.

use super::Layout;
use crate::record::Record;
use nalgebra::DMatrix;
use num_complex::Complex;
use rayon::prelude::*;
use rustfft::FftPlanner;
use std::cell::RefCell;

/// FFT length for the correlations of records longer than one block: each block of
/// `FFT_BLOCK - dmax` samples is transformed with its next `dmax` samples.
const FFT_BLOCK: usize = 8192;

thread_local! {
    /// FFT plans are cached per thread (a plan is pure: the results do not depend on
    /// which thread made it).
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
}

/// Smallest `2^a 3^b` (`b <= 2`) at least `n`: lengths that the FFT handles fastest.
fn fft_len(n: usize) -> usize {
    [1, 3, 9]
        .iter()
        .map(|&f| {
            let mut v = f;
            while v < n {
                v *= 2;
            }
            v
        })
        .min()
        .unwrap_or(n)
}

/// Full correlations `sum_k x_a[k] x_b[k + d]` (samples outside `0 .. len` are zero) of
/// every ordered channel pair `(a, b)` for `d = 0 ..= dmax`, at index
/// `(a * nch + b) * (dmax + 1) + d`. Channel `c` is `ins[c + r k]` for `c < r` and
/// `outs[c - r + m k]` otherwise (column-major records).
///
/// By FFT: with `A_a` the transform of a block of channel `a` and `E_b` that of the same
/// block of channel `b` extended by the next `dmax` samples (zero-padded to a length of
/// at least their sum, so that no lag up to `dmax` wraps around), `conj(A_a) E_b` is the
/// transform of the block's share of the correlation; the shares are summed as spectra
/// and transformed back once. Two real channels share each complex transform. A record
/// that fits one block (`len + dmax` at most the transform length) needs no extension:
/// then the spectrum of `(b, a)` is the conjugate of that of `(a, b)`, and one inverse
/// transform gives both (`(a, b)` at lags `d`, `(b, a)` at lags `n_fft - d`), so only the
/// pairs `a <= b` are transformed (against transforming all of them, the identification
/// of the 5-hit golden campaign moved by round-off: M by 2e-12 relative, K by 4e-14, its
/// weakest Hankel singular values by 5e-9, measured). Round-off is that of the FFT, of
/// order `eps log2(n)` relative to `sqrt(sum x_a^2 sum x_b^2)`: the Gram matrix stays
/// within the 1e-12 of its scale of the direct sums that
/// `lagged_products_equal_the_gram_matrix_of_the_regression` asks, and M and K of paper
/// case 1 (10 hits) moved by 3e-13 relative against the direct sums (measured).
fn full_correlations(
    ins: &[f64],
    outs: &[f64],
    r: usize,
    m: usize,
    len: usize,
    dmax: usize,
) -> Vec<f64> {
    type C = Complex<f64>;
    let zero = C::new(0.0, 0.0);
    let nch = r + m;
    let channel = |c: usize| -> (&[f64], usize) {
        if c < r {
            (&ins[c..], r)
        } else {
            (&outs[c - r..], m)
        }
    };
    let one_block = len + dmax <= FFT_BLOCK.max(4 * (dmax + 1));
    let n_fft = if one_block {
        fft_len(len + dmax)
    } else {
        fft_len(FFT_BLOCK.max(4 * (dmax + 1)))
    };
    let block = n_fft - dmax;
    let half = n_fft / 2 + 1;
    let (fwd, inv) = PLANNER.with(|p| {
        let mut p = p.borrow_mut();
        (p.plan_fft_forward(n_fft), p.plan_fft_inverse(n_fft))
    });
    let mut scratch = vec![
        zero;
        fwd.get_inplace_scratch_len()
            .max(inv.get_inplace_scratch_len())
    ];
    let mut buf = vec![zero; n_fft];
    // Half spectra (bins 0 ..= n/2) of the block (`short`) and of the extended block.
    let mut short = vec![zero; nch * half];
    let mut ext = if one_block {
        Vec::new()
    } else {
        vec![zero; nch * half]
    };
    // Transforms of channels `c .. c + 2` over samples `k0 .. k0 + count`.
    let mut spectra = |out: &mut [C], k0: usize, count: usize| {
        for c in (0..nch).step_by(2) {
            let pair = c + 1 < nch;
            let (xa, sa) = channel(c);
            let (head, tail) = buf.split_at_mut(count);
            if pair {
                let (xb, sb) = channel(c + 1);
                for (j, v) in head.iter_mut().enumerate() {
                    let k = k0 + j;
                    *v = C::new(xa[sa * k], xb[sb * k]);
                }
            } else {
                for (j, v) in head.iter_mut().enumerate() {
                    *v = C::new(xa[sa * (k0 + j)], 0.0);
                }
            }
            tail.fill(zero);
            fwd.process_with_scratch(&mut buf, &mut scratch);
            for f in 0..half {
                let z = buf[f];
                let zc = buf[(n_fft - f) % n_fft].conj();
                if pair {
                    out[c * half + f] = (z + zc) * 0.5;
                    out[(c + 1) * half + f] = (z - zc) * C::new(0.0, -0.5);
                } else {
                    out[c * half + f] = z;
                }
            }
        }
    };
    // The cross-spectra transformed back: every ordered pair, or with one block only
    // `a <= b` (the others by symmetry).
    let pairs: Vec<(usize, usize)> = (0..nch)
        .flat_map(|a| (0..nch).map(move |b| (a, b)))
        .filter(|&(a, b)| !one_block || a <= b)
        .collect();
    let mut spec = Vec::with_capacity(pairs.len() * half);
    if one_block {
        spectra(&mut short, 0, len);
        for &(a, b) in &pairs {
            let sa = &short[a * half..(a + 1) * half];
            let sb = &short[b * half..(b + 1) * half];
            spec.extend(sa.iter().zip(sb).map(|(x, y)| x.conj() * y));
        }
    } else {
        spec.resize(pairs.len() * half, zero);
        let mut k0 = 0;
        while k0 < len {
            let n = block.min(len - k0);
            let ne = (n + dmax).min(len - k0);
            spectra(&mut short, k0, n);
            let e = if ne > n {
                spectra(&mut ext, k0, ne);
                &ext
            } else {
                &short
            };
            for (p, &(a, b)) in pairs.iter().enumerate() {
                let sa = &short[a * half..(a + 1) * half];
                let eb = &e[b * half..(b + 1) * half];
                for ((v, x), y) in spec[p * half..(p + 1) * half].iter_mut().zip(sa).zip(eb) {
                    *v += x.conj() * y;
                }
            }
            k0 += n;
        }
    }
    let stride = dmax + 1;
    let mut corr = vec![0.0; nch * nch * stride];
    let scale = 1.0 / n_fft as f64;
    // Lags `d` of pair `(a, b)`, and with one block lags `n - d` for `(b, a)`.
    let mut store = |(a, b): (usize, usize), value: &dyn Fn(usize) -> f64| {
        for d in 0..stride {
            corr[(a * nch + b) * stride + d] = value(d) * scale;
        }
        if one_block && a != b {
            for d in 0..stride {
                corr[(b * nch + a) * stride + d] = value((n_fft - d) % n_fft) * scale;
            }
        }
    };
    for first in (0..pairs.len()).step_by(2) {
        let second = (first + 1 < pairs.len()).then_some(first + 1);
        // Full spectrum of s1 + i s2 from the half spectra of the real s1, s2.
        let s1 = &spec[first * half..(first + 1) * half];
        let s2 = second.map(|sec| &spec[sec * half..(sec + 1) * half]);
        let (lower, upper) = buf.split_at_mut(half);
        match s2 {
            Some(s2) => {
                for f in 0..half {
                    lower[f] = s1[f] + C::new(-s2[f].im, s2[f].re);
                }
                for (i, v) in upper.iter_mut().enumerate() {
                    let g = n_fft - half - i;
                    let (a, b) = (s1[g].conj(), s2[g].conj());
                    *v = a + C::new(-b.im, b.re);
                }
            }
            None => {
                lower.copy_from_slice(s1);
                for (i, v) in upper.iter_mut().enumerate() {
                    *v = s1[n_fft - half - i].conj();
                }
            }
        }
        inv.process_with_scratch(&mut buf, &mut scratch);
        store(pairs[first], &|i| buf[i].re);
        if let Some(second) = second {
            store(pairs[second], &|i| buf[i].im);
        }
    }
    corr
}

/// Gram matrix of the OKID regression of some records, in the records' units.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Moments {
    /// Layout the Gram matrix was built for (its order is the largest usable).
    pub(crate) layout: Layout,
    /// `columns(p) + m` square, regressors then targets, raw units.
    pub(super) gram: DMatrix<f64>,
    /// Sum of squares of every channel (inputs then outputs) over all samples.
    channel_ss: Vec<f64>,
    /// Samples in all records.
    samples: usize,
    /// Equations (rows) of the stacked regression.
    pub(crate) equations: usize,
}

/// Channel (inputs first, then outputs) and lag of regression column `j`; the targets
/// follow the regressors at lag 0.
fn column(layout: &Layout, j: usize) -> (usize, isize) {
    let (r, m, q, p) = (layout.r, layout.m, layout.q, layout.p);
    if j < q * r {
        (j % r, -((q - j / r) as isize))
    } else if j < (q + 1) * r {
        (j - q * r, 0)
    } else if j < layout.columns(p) {
        let k = j - (q + 1) * r;
        let lag = (k / (r + m) + 1) as isize;
        (k % (r + m), lag)
    } else {
        (r + j - layout.columns(p), 0)
            .min((r + m - 1, 0))
            .max((r, 0))
    }
}

impl Moments {
    /// Zero moments for `layout`.
    pub(crate) fn zeros(layout: &Layout) -> Self {
        let w = layout.columns(layout.p) + layout.m;
        Self {
            layout: *layout,
            gram: DMatrix::zeros(w, w),
            channel_ss: vec![0.0; layout.r + layout.m],
            samples: 0,
            equations: 0,
        }
    }

    /// Sum of the moments of `records`, in order. The records' moments are computed in
    /// parallel and summed in record order, so the sum does not depend on the threads.
    pub(crate) fn of_records(records: &[&Record], layout: &Layout) -> Self {
        let each: Vec<Self> = records
            .par_iter()
            .map(|rec| Self::of_record(rec, layout))
            .collect();
        let mut total = Self::zeros(layout);
        for moments in &each {
            total.add(moments);
        }
        total
    }

    /// Adds another set of records' moments.
    pub(crate) fn add(&mut self, other: &Moments) {
        assert_eq!(
            self.layout.columns(self.layout.p),
            other.layout.columns(other.layout.p)
        );
        self.gram += &other.gram;
        for (a, b) in self.channel_ss.iter_mut().zip(&other.channel_ss) {
            *a += b;
        }
        self.samples += other.samples;
        self.equations += other.equations;
    }

    /// These moments without those of `other` (a subset of the same records).
    pub(crate) fn without(&self, other: &Moments) -> Moments {
        let mut out = self.clone();
        out.gram -= &other.gram;
        for (a, b) in out.channel_ss.iter_mut().zip(&other.channel_ss) {
            *a = (*a - b).max(0.0);
        }
        out.samples -= other.samples;
        out.equations -= other.equations;
        out
    }

    /// Moments of one record (at least `p + q + 1` samples long).
    pub(crate) fn of_record(rec: &Record, layout: &Layout) -> Self {
        let (r, m, q, p) = (layout.r, layout.m, layout.q, layout.p);
        let nch = r + m;
        let len = rec.len();
        let skip = layout.skip;
        assert!(len > p + q + skip, "OKID moments: record too short");
        let n_eq = len - q;
        let (ins, outs) = (rec.inputs.as_slice(), rec.outputs.as_slice());
        let x = |ch: usize, k: usize| -> f64 {
            if ch < r {
                ins[ch + r * k]
            } else {
                outs[ch - r + m * k]
            }
        };
        // Largest lag difference d = l1 - l2 >= 0 needed: the largest lag minus the
        // smallest.
        let dmax = p + q;
        let stride = dmax + 1;
        let corr = full_correlations(ins, outs, r, m, len, dmax);
        // The regression leaves out, of the full correlation sum_k x_a[k] x_b[k + d], the
        // first few and the last few products (see below): partial sums of those products
        // from the record's start (`head`) and back from its end (`tail`), for every
        // channel pair and lag difference -dmax ..= dmax, so that each Gram entry costs
        // two look-ups.
        let lags = 2 * dmax + 1;
        let head_max = skip + q;
        let tail_max = p + q;
        // Filled slot by slot in order (no zeroing first).
        let mut head = Vec::with_capacity(nch * nch * lags * (head_max + 1));
        let mut tail = Vec::with_capacity(nch * nch * lags * (tail_max + 1));
        // The first and last samples those sums reach, per channel, zero outside the record.
        let span_head = 2 * dmax + head_max + 1;
        let span_tail = 2 * dmax + tail_max + 1;
        let (len_i, n_eq_i) = (len as isize, n_eq as isize);
        let first: Vec<Vec<f64>> = (0..nch)
            .map(|ch| {
                (0..span_head)
                    .map(|k| if k < len { x(ch, k) } else { 0.0 })
                    .collect()
            })
            .collect();
        let last: Vec<Vec<f64>> = (0..nch)
            .map(|ch| {
                (0..span_tail)
                    .map(|i| {
                        let k = len_i - span_tail as isize + i as isize;
                        if k >= 0 { x(ch, k as usize) } else { 0.0 }
                    })
                    .collect()
            })
            .collect();
        for a in 0..nch {
            for b in 0..nch {
                for di in 0..lags {
                    let d = di as isize - dmax as isize;
                    let slot = (a * nch + b) * lags + di;
                    // Head: k = full_lo + t with full_lo = max(0, -d).
                    let lo = 0.max(-d) as usize;
                    let (ha, hb) = (
                        &first[a][lo..lo + head_max],
                        &first[b][(lo as isize + d) as usize..][..head_max],
                    );
                    debug_assert_eq!(head.len(), slot * (head_max + 1));
                    head.push(0.0);
                    head.extend(ha.iter().zip(hb).scan(0.0, |sum, (x, y)| {
                        *sum += x * y;
                        Some(*sum)
                    }));
                    // Tail: k = full_hi - t with full_hi = len - 1 - max(0, d), sample
                    // `ia - t` of `last[a]` and `ib - t` of `last[b]`.
                    let ia = span_tail - 1 - 0.max(d) as usize;
                    let ib = (ia as isize + d) as usize;
                    let (ta, tb) = (
                        &last[a][ia + 1 - tail_max..=ia],
                        &last[b][ib + 1 - tail_max..=ib],
                    );
                    debug_assert_eq!(tail.len(), slot * (tail_max + 1));
                    tail.push(0.0);
                    tail.extend(
                        ta.iter()
                            .rev()
                            .zip(tb.iter().rev())
                            .scan(0.0, |sum, (x, y)| {
                                *sum += x * y;
                                Some(*sum)
                            }),
                    );
                }
            }
        }
        let w = layout.columns(p) + m;
        let cols: Vec<(usize, isize)> = (0..w).map(|j| column(layout, j)).collect();
        let mut gram = DMatrix::zeros(w, w);
        for i in 0..w {
            let (a, l1) = cols[i];
            for j in i..w {
                let (b, l2) = cols[j];
                let d = l1 - l2;
                let full = if d >= 0 {
                    corr[(a * nch + b) * stride + d as usize]
                } else {
                    corr[(b * nch + a) * stride + (-d) as usize]
                };
                // Sum over k (sample of channel a) of x_a[k] x_b[k + d]: the full
                // correlation runs over max(0, -d) ..= min(len - 1, len - 1 - d); the
                // regression over max(0, -d, skip - l1) ..= n_eq - 1 - l1 (equations
                // n = skip .. n_eq - 1, sample k = n - l1 of channel a).
                let full_lo = 0.max(-d);
                let lo = full_lo.max(skip as isize - l1);
                let full_hi = (len_i - 1).min(len_i - 1 - d);
                let hi = n_eq_i - 1 - l1;
                let slot = (a * nch + b) * lags + (d + dmax as isize) as usize;
                let head_len = (lo - full_lo) as usize;
                let tail_len = (full_hi - hi).max(0) as usize;
                debug_assert!(head_len <= head_max && tail_len <= tail_max);
                let outside =
                    head[slot * (head_max + 1) + head_len] + tail[slot * (tail_max + 1) + tail_len];
                let v = full - outside;
                gram[(i, j)] = v;
                gram[(j, i)] = v;
            }
        }
        let channel_ss = (0..nch).map(|ch| corr[(ch * nch + ch) * stride]).collect();
        Self {
            layout: *layout,
            gram,
            channel_ss,
            samples: len,
            equations: n_eq - skip,
        }
    }

    /// RMS scales of the channels (1 for a channel that is zero everywhere).
    pub(super) fn scales(&self) -> super::Scales {
        let r = self.layout.r;
        let rms = |ss: f64| {
            let v = (ss / self.samples as f64).sqrt();
            if v > 0.0 && v.is_finite() { v } else { 1.0 }
        };
        super::Scales {
            u: self.channel_ss[..r].iter().map(|&ss| rms(ss)).collect(),
            y: self.channel_ss[r..].iter().map(|&ss| rms(ss)).collect(),
        }
    }

    /// Gram matrix of the regression at `layout` (same leads, order at most the moments'),
    /// with every channel divided by its scale.
    pub(super) fn scaled_gram(&self, layout: &Layout, s: &super::Scales) -> DMatrix<f64> {
        let own = &self.layout;
        let (r, m) = (own.r, own.m);
        let c = layout.columns(layout.p);
        let own_c = own.columns(own.p);
        let index = |j: usize| if j < c { j } else { own_c + j - c };
        let scale = |j: usize| {
            let (ch, _) = column(layout, j);
            if ch < r { s.u[ch] } else { s.y[ch - r] }
        };
        let w = c + m;
        let scales: Vec<f64> = (0..w).map(scale).collect();
        DMatrix::from_fn(w, w, |i, j| {
            self.gram[(index(i), index(j))] / (scales[i] * scales[j])
        })
    }
}

/// Residual sum of squares (scaled units) of every nested order `p = 1..=layout.p`
/// (index `p - 1`) from a Cholesky elimination of the scaled Gram matrix, regressors in
/// order. `None` if a pivot falls below `PIVOT_LIMIT` of its column's own sum of squares:
/// the regression is too ill-conditioned for the normal equations.
pub(crate) fn nested_rss(gram: &DMatrix<f64>, layout: &Layout) -> Option<Vec<f64>> {
    let ncols = layout.columns(layout.p);
    let w = gram.nrows();
    let mut a = gram.clone();
    let mut rss = Vec::with_capacity(layout.p);
    let trace = |a: &DMatrix<f64>| (ncols..w).map(|i| a[(i, i)]).sum::<f64>();
    for k in 0..ncols {
        let d = a[(k, k)];
        if !(d.is_finite() && d > super::PIVOT_LIMIT * gram[(k, k)]) {
            return None;
        }
        for j in k + 1..w {
            let f = a[(j, k)] / d;
            if f == 0.0 {
                continue;
            }
            for i in j..w {
                a[(i, j)] -= f * a[(i, k)];
            }
        }
        if k + 1 > layout.columns(0)
            && (k + 1 - layout.columns(0)).is_multiple_of(layout.r + layout.m)
        {
            rss.push(trace(&a));
        }
    }
    debug_assert_eq!(rss.len(), layout.p);
    Some(rss)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::normal;
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;

    /// The full correlations when the largest lag difference sets the transform length
    /// (`4 (dmax + 1)` above the 8192 block: observer orders past 2047, too large for the
    /// Gram oracle), on both sides of the one-block limit `len + dmax = 4 (dmax + 1)` and
    /// over several blocks, against the naive sums at the first, middle and last lags of
    /// every ordered channel pair (one input, two outputs: an odd channel count, one
    /// channel transformed alone).
    #[test]
    fn full_correlations_with_the_lags_setting_the_transform_length() {
        let mut rng = ChaCha8Rng::seed_from_u64(74);
        let (r, m, dmax) = (1, 2, 2100);
        let limit = 4 * (dmax + 1) - dmax;
        let mut worst = 0.0f64;
        for len in [limit - 1, limit, limit + 1, 3 * limit + 5] {
            let ins: Vec<f64> = (0..r * len).map(|_| normal(&mut rng)).collect();
            let outs: Vec<f64> = (0..m * len).map(|_| normal(&mut rng) + 0.5).collect();
            let corr = full_correlations(&ins, &outs, r, m, len, dmax);
            let nch = r + m;
            let x = |c: usize, k: usize| {
                if c < r {
                    ins[c + r * k]
                } else {
                    outs[c - r + m * k]
                }
            };
            let ss: Vec<f64> = (0..nch)
                .map(|c| (0..len).map(|k| x(c, k).powi(2)).sum())
                .collect();
            for a in 0..nch {
                for b in 0..nch {
                    for d in [0, 1, 2, dmax / 2, dmax - 1, dmax] {
                        let want: f64 = (0..len.saturating_sub(d))
                            .map(|k| x(a, k) * x(b, k + d))
                            .sum();
                        let got = corr[(a * nch + b) * (dmax + 1) + d];
                        let e = (got - want).abs() / (ss[a] * ss[b]).sqrt();
                        worst = worst.max(e);
                        // FFT round-off, eps log2(n) of sqrt(sum x_a^2 sum x_b^2) (the
                        // docs of `full_correlations`): 1e-12 leaves room for the block
                        // sums (measured 4.2e-15); one product missing is 4e-5 of the
                        // scale or more.
                        assert!(e < 1e-12, "len {len} ({a}, {b}) lag {d}: {e:e}");
                    }
                }
            }
        }
        eprintln!("worst relative difference: {worst:e}");
    }
}
