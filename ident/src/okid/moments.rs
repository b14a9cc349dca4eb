//! Lagged products of the records: the normal equations of the OKID regression.
//!
//! Every entry of the Gram matrix `[X | Y]^T [X | Y]` of the stacked regression is a sum
//! over samples of a product of two channels at two lags. For one record it is the full
//! cross-correlation of the two channels at the lag difference, minus the few products
//! that the zero-initial-condition form leaves out at the record's start (leads) and end
//! (the last `q + lag` samples). The correlations are computed once per record, in blocks
//! of samples so that long records need no copies, and summed over the records; a
//! leave-one-record-out Gram matrix is the sum minus that record's contribution.

use super::Layout;
use crate::record::Record;
use nalgebra::DMatrix;

/// Samples per block of the correlation sums (the block and its margin of lags are copied
/// into contiguous buffers).
const BLOCK: usize = 4096;

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

/// Lags computed together by [`dots`].
const LAGS: usize = 4;

/// `sum_k a[k] b[k + j]` for `j = 0 .. LAGS` (`b` at least `a.len() + LAGS - 1` long): each
/// sample of `a` is loaded once for four lags, two samples at a time (independent sums).
fn dots(a: &[f64], b: &[f64]) -> [f64; LAGS] {
    let n = a.len();
    let b = &b[..n + LAGS - 1];
    let mut even = [0.0f64; LAGS];
    let mut odd = [0.0f64; LAGS];
    let pairs = n / 2;
    for p in 0..pairs {
        let k = 2 * p;
        let (x0, x1) = (a[k], a[k + 1]);
        let w: &[f64; LAGS + 1] = b[k..k + LAGS + 1].try_into().expect("window");
        for j in 0..LAGS {
            even[j] += x0 * w[j];
            odd[j] += x1 * w[j + 1];
        }
    }
    if n % 2 == 1 {
        let k = n - 1;
        for j in 0..LAGS {
            even[j] += a[k] * b[k + j];
        }
    }
    let mut out = [0.0; LAGS];
    for j in 0..LAGS {
        out[j] = even[j] + odd[j];
    }
    out
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

    /// Sum of the moments of `records`, in order.
    pub(crate) fn of_records(records: &[&Record], layout: &Layout) -> Self {
        let mut total = Self::zeros(layout);
        for rec in records {
            total.add(&Self::of_record(rec, layout));
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
        // Largest lag difference d = l1 - l2 >= 0 needed for channels (a, b): the largest
        // lag of a minus the smallest lag of b.
        let dmax = p + q;
        let reach = |b: usize| if b < r { p + q } else { p };
        let stride = dmax + 1;
        let mut corr = vec![0.0; nch * nch * stride];
        // Samples past the record's end read as zero, so every lag sums over the whole
        // block; the margin covers the largest lag rounded up to whole groups of lags.
        let margin = dmax.div_ceil(LAGS) * LAGS + LAGS;
        let mut bufs = vec![vec![0.0; BLOCK + margin]; nch];
        let mut k0 = 0;
        while k0 < len {
            let k1 = (k0 + BLOCK).min(len);
            let end = (k1 + margin).min(len);
            for (ch, buf) in bufs.iter_mut().enumerate() {
                let (filled, rest) = buf.split_at_mut(end - k0);
                for (j, v) in filled.iter_mut().enumerate() {
                    *v = x(ch, k0 + j);
                }
                rest.fill(0.0);
            }
            let n = k1 - k0;
            for a in 0..nch {
                for b in 0..nch {
                    let base = (a * nch + b) * stride;
                    for d0 in (0..=reach(b)).step_by(LAGS) {
                        let sums = dots(&bufs[a][..n], &bufs[b][d0..]);
                        for (j, v) in sums.iter().enumerate() {
                            if d0 + j <= reach(b) {
                                corr[base + d0 + j] += v;
                            }
                        }
                    }
                }
            }
            k0 = k1;
        }
        // The regression leaves out, of the full correlation sum_k x_a[k] x_b[k + d], the
        // first few and the last few products (see below): partial sums of those products
        // from the record's start (`head`) and back from its end (`tail`), for every
        // channel pair and lag difference -dmax ..= dmax, so that each Gram entry costs
        // two look-ups.
        let lags = 2 * dmax + 1;
        let head_max = skip + q;
        let tail_max = p + q;
        let mut head = vec![0.0; nch * nch * lags * (head_max + 1)];
        let mut tail = vec![0.0; nch * nch * lags * (tail_max + 1)];
        let (len_i, n_eq_i) = (len as isize, n_eq as isize);
        for a in 0..nch {
            for b in 0..nch {
                for di in 0..lags {
                    let d = di as isize - dmax as isize;
                    let slot = (a * nch + b) * lags + di;
                    let full_lo = 0.max(-d);
                    let full_hi = (len_i - 1).min(len_i - 1 - d);
                    let h = &mut head[slot * (head_max + 1)..(slot + 1) * (head_max + 1)];
                    let mut sum = 0.0;
                    for t in 0..head_max {
                        let k = full_lo + t as isize;
                        if k <= full_hi {
                            sum += x(a, k as usize) * x(b, (k + d) as usize);
                        }
                        h[t + 1] = sum;
                    }
                    let tl = &mut tail[slot * (tail_max + 1)..(slot + 1) * (tail_max + 1)];
                    let mut sum = 0.0;
                    for t in 0..tail_max {
                        let k = full_hi - t as isize;
                        if k >= full_lo {
                            sum += x(a, k as usize) * x(b, (k + d) as usize);
                        }
                        tl[t + 1] = sum;
                    }
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
