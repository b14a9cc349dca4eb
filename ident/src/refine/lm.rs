//! Levenberg-Marquardt on a projected nonlinear least-squares cost `sum r^2`, with Moré's
//! diagonal scaling (largest `sqrt(F_ii)` seen so far) and Nielsen's damping update (with a lower
//! floor for the refinement from records, [`DAMPING_DECREASE_FLOOR`]). Steps
//! the model rejects (M or K not positive definite, no finite response) are treated as
//! steps that increase the cost.

use super::StopReason;
use nalgebra::{DMatrix, DVector};

/// Settings of one run.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Settings {
    pub max_iterations: usize,
    pub gradient_tolerance: f64,
    pub step_tolerance: f64,
    pub cost_tolerance: f64,
    /// Absolute tolerance on the decrease of the cost a full Gauss-Newton step would bring
    /// (0: only the relative `cost_tolerance`).
    pub decrease_tolerance: f64,
    /// Smallest factor of the damping update after an accepted step: [`NIELSEN_FLOOR`] or
    /// [`DAMPING_DECREASE_FLOOR`].
    pub damping_floor: f64,
}

/// What the cost function returns at a point: cost, Gauss-Newton matrix `J^T J` and
/// `J^T r`; `None` if the point is not admissible.
pub(crate) struct Point<E> {
    pub cost: f64,
    pub fisher: DMatrix<f64>,
    pub gradient: DVector<f64>,
    pub extra: E,
}

/// Levenberg–Marquardt damping of a cold start, relative to the unit diagonal of the scaled
/// Gauss-Newton matrix.
pub(crate) const INITIAL_DAMPING: f64 = 1e-3;

/// Nielsen's smallest factor of the damping update after an accepted step (see
/// [`DAMPING_DECREASE_FLOOR`]); the FRF refinement's.
pub(crate) const NIELSEN_FLOOR: f64 = 1.0 / 3.0;

/// Smallest factor of the damping update after an accepted step in the refinement from records
/// (`crate::refine::Refiner`), `mu *= max(floor, 1 - (2 rho - 1)^3)` (`rho`: actual over predicted
/// decrease). Nielsen's own floor is 1/3; the factor is below that only where `rho` is above 0.937
/// (the quadratic model predicted the step's decrease within about 6 %, or the cost fell by more
/// than predicted) and reaches this floor above 0.998. There the damping only slows the convergence
/// along the weakly determined directions of the scaled Gauss-Newton matrix (the damping ratio `mu
/// / (lambda + mu)` of an eigenvalue `lambda` is what is left of the step there). A rejected step
/// still multiplies the damping by 2, 4, 8, ... Measured on the refinements of twenty analyzer and
/// five held 10-hit paper-case-1 campaigns (1 % noise), in Jacobian-evaluation equivalents (a
/// cost-only evaluation a quarter, one without the weights' derivative two thirds):
///
/// | floor | analyzer (20) | held (5) |
/// |---|---|---|
/// | 1/3 | 153.4 | 136.3 |
/// | 1/10 | 124.1 | 131.2 |
/// | 1/100 | 107.4 (-30 %) | 143.9 (+6 %) |
///
/// With 1/100 an analyzer campaign takes three or four evaluations with the Jacobian instead of six
/// (`cJJcJcJFc` or `cJcJcJFc` in place of `cJJcJJcJJFc`: c cost only, J Jacobian, F without the
/// weights' derivative). The refined parameters moved by at most 2.4e-3 of their standard
/// deviations on the analyzer campaigns (their standard deviations by 1.3e-4 relative, the noise
/// levels by 4.6e-4), and by at most 6.9e-2 on the held ones, whose alternation of noise fit and
/// refinement stops farther from its fixed point (see [`super::NOISE_CHANGE_TOLERANCE`]: a fourth
/// noise update moves them by 0.40). The FRF refinement (`crate::frf::refine`) keeps
/// [`NIELSEN_FLOOR`]: with this floor its shear-frame fit of the measured Cristallo FRFs
/// (`tests/cli_frf.rs`, `python/tests/test_frf.py`) ended at other floor masses (5.41, 5.29, 5.00
/// kg against 5.91, 5.23, 5.03) with standard errors five to twenty times larger, a worse point of
/// that misspecified model's cost.
pub(crate) const DAMPING_DECREASE_FLOOR: f64 = 0.01;

/// Nielsen's update of the damping `mu` after an accepted step whose actual decrease is `rho`
/// times the predicted one: `mu max(floor, 1 - (2 rho - 1)^3)`.
fn decreased_damping(mu: f64, rho: f64, floor: f64) -> f64 {
    mu * (1.0 - (2.0 * rho - 1.0).powi(3)).max(floor)
}

/// Regularization of the scaled Gauss-Newton matrix (unit diagonal) when the full step's
/// predicted decrease is computed.
const GAUSS_NEWTON_REGULARIZATION: f64 = 1e-12;

/// Result of a run.
pub(crate) struct Outcome<E> {
    pub theta: DVector<f64>,
    pub point: Point<E>,
    /// Damping at the end (a warm start for a following run).
    pub damping: f64,
    /// Steps tried (accepted or not).
    pub iterations: usize,
    pub stop: StopReason,
}

/// `max_i |g_i| / sqrt(F_ii cost)`: the largest cosine between the residual and a Jacobian
/// column (0 for a zero residual).
pub(crate) fn gradient_cosine(fisher: &DMatrix<f64>, gradient: &DVector<f64>, cost: f64) -> f64 {
    if cost <= 0.0 {
        return 0.0;
    }
    (0..gradient.len())
        .filter(|&i| fisher[(i, i)] > 0.0)
        .map(|i| gradient[i].abs() / (fisher[(i, i)] * cost).sqrt())
        .fold(0.0, f64::max)
}

/// Minimizes from `theta` (which must be admissible, `start` is its evaluation) with
/// initial damping `mu`. `eval` also gets the decrease of the cost the step's quadratic model
/// predicts (a hint that the point may be the last).
pub(crate) fn minimize<E>(
    theta: DVector<f64>,
    start: Point<E>,
    settings: Settings,
    mu: f64,
    eval: impl FnMut(&DVector<f64>, f64) -> Option<Point<E>>,
) -> Outcome<E> {
    let (outcome, _) = iterate(theta, start, settings, mu, eval, None::<NoTail<E>>);
    outcome
}

/// A point evaluated by the tail evaluation (its cost and `extra`, no Gauss-Newton matrix),
/// where a run ended (see [`minimize_to_tail`]; the point is its `theta`).
pub(crate) struct TailPoint<E> {
    pub cost: f64,
    pub extra: E,
}

/// The last point of [`minimize_to_tail`]: evaluated with the Jacobian, or by the tail
/// evaluation.
pub(crate) enum End<E> {
    Point(Point<E>),
    Tail(TailPoint<E>),
}

/// Result of [`minimize_to_tail`].
pub(crate) struct TailOutcome<E> {
    pub theta: DVector<f64>,
    pub end: End<E>,
    pub damping: f64,
    pub iterations: usize,
    pub stop: StopReason,
}

/// Like [`minimize`], for a run whose last point needs only its cost and `extra` (what
/// `eval_tail` computes, cheaper than `eval`): a step whose quadratic model leaves at most the
/// run's stop threshold of the decrease a full Gauss-Newton step would bring (`d - predicted`
/// with `d` that decrease; the threshold is `cost_tolerance` times the cost or
/// `decrease_tolerance`, whichever is larger, the one the run also stops at when `d` itself is
/// below it) is evaluated by `eval_tail` alone, and the run ends at the point it reaches if the
/// cost went down and the actual decrease matches the predicted one within the threshold (the
/// model, which says what is left, is that accurate there; an actual decrease beyond the
/// prediction says it is not either). Otherwise the point is evaluated again by `eval` (if the
/// cost went down) and the run goes on as [`minimize`] would: only the `eval_tail` evaluation
/// is lost.
pub(crate) fn minimize_to_tail<E>(
    theta: DVector<f64>,
    start: Point<E>,
    settings: Settings,
    mu: f64,
    eval: impl FnMut(&DVector<f64>, f64) -> Option<Point<E>>,
    eval_tail: impl FnMut(&DVector<f64>) -> Option<(f64, E)>,
) -> TailOutcome<E> {
    let (outcome, tail) = iterate(theta, start, settings, mu, eval, Some(eval_tail));
    TailOutcome {
        theta: outcome.theta,
        end: match tail {
            Some(tail) => End::Tail(tail),
            None => End::Point(outcome.point),
        },
        damping: outcome.damping,
        iterations: outcome.iterations,
        stop: outcome.stop,
    }
}

/// The tail evaluation of [`minimize`], which never takes a tail step.
type NoTail<E> = fn(&DVector<f64>) -> Option<(f64, E)>;

/// The Levenberg–Marquardt loop. With `eval_tail`, the run may end at a point evaluated by
/// it: the outcome's `theta` is then that point, whose evaluation is returned beside it
/// (`point` stays the last one with the Jacobian).
fn iterate<E, F: FnMut(&DVector<f64>) -> Option<(f64, E)>>(
    theta: DVector<f64>,
    start: Point<E>,
    settings: Settings,
    mu: f64,
    mut eval: impl FnMut(&DVector<f64>, f64) -> Option<Point<E>>,
    mut eval_tail: Option<F>,
) -> (Outcome<E>, Option<TailPoint<E>>) {
    let p = theta.len();
    let mut theta = theta;
    let mut point = start;
    let mut scale = DVector::from_fn(p, |i, _| {
        let d = point.fisher[(i, i)].max(0.0).sqrt();
        if d > 0.0 { d } else { 1.0 }
    });
    let mut mu = mu;
    let mut nu = 2.0;
    let mut iterations = 0;
    let mut ended = None;
    let stop = loop {
        if gradient_cosine(&point.fisher, &point.gradient, point.cost)
            <= settings.gradient_tolerance
        {
            break StopReason::Gradient;
        }
        if iterations >= settings.max_iterations {
            break StopReason::MaxIterations;
        }
        iterations += 1;
        let fs = DMatrix::from_fn(p, p, |i, j| point.fisher[(i, j)] / (scale[i] * scale[j]));
        let gs = DVector::from_fn(p, |i, _| point.gradient[i] / scale[i]);
        // Decrease a full Gauss-Newton step would bring: below the cost tolerance there is
        // nothing left to gain (checked before paying for an evaluation).
        let mut gn = fs.clone();
        for i in 0..p {
            gn[(i, i)] += GAUSS_NEWTON_REGULARIZATION;
        }
        let full_decrease = gn.cholesky().map(|chol| gs.dot(&chol.solve(&gs)));
        let threshold = (settings.cost_tolerance * point.cost).max(settings.decrease_tolerance);
        if full_decrease.is_some_and(|d| d <= threshold) {
            break StopReason::Cost;
        }
        let mut lhs = fs.clone();
        for i in 0..p {
            lhs[(i, i)] += mu;
        }
        let Some(chol) = lhs.cholesky() else {
            mu *= nu;
            nu *= 2.0;
            if mu > 1e30 {
                break StopReason::NoProgress;
            }
            continue;
        };
        let ds = -chol.solve(&gs);
        let delta = DVector::from_fn(p, |i, _| ds[i] / scale[i]);
        let predicted = -2.0 * gs.dot(&ds) - ds.dot(&(&fs * &ds));
        let theta_norm = DVector::from_fn(p, |i, _| theta[i] * scale[i]).norm();
        let small_step =
            ds.norm() <= settings.step_tolerance * (theta_norm + settings.step_tolerance);
        let candidate = &theta + &delta;
        let trial = match (&mut eval_tail, full_decrease) {
            (Some(eval_tail), Some(d)) if predicted > 0.0 && d - predicted <= threshold => {
                match eval_tail(&candidate).filter(|(cost, _)| cost.is_finite()) {
                    Some((cost, extra))
                        if point.cost - cost > 0.0
                            && (point.cost - cost - predicted).abs() <= threshold =>
                    {
                        let rho = (point.cost - cost) / predicted;
                        mu = decreased_damping(mu, rho, settings.damping_floor);
                        theta = candidate;
                        ended = Some(TailPoint { cost, extra });
                        break StopReason::Cost;
                    }
                    // Better, but the model was not that accurate: the Jacobian there after all.
                    Some((cost, _)) if point.cost - cost > 0.0 => eval(&candidate, predicted),
                    _ => None,
                }
            }
            _ => eval(&candidate, predicted),
        }
        .filter(|t| t.cost.is_finite());
        let actual = trial.as_ref().map(|t| point.cost - t.cost);
        match (trial, actual) {
            (Some(trial), Some(actual)) if actual > 0.0 && predicted > 0.0 => {
                let rho = actual / predicted;
                let old_cost = point.cost;
                theta = candidate;
                point = trial;
                mu = decreased_damping(mu, rho, settings.damping_floor);
                nu = 2.0;
                for i in 0..p {
                    scale[i] = scale[i].max(point.fisher[(i, i)].max(0.0).sqrt());
                }
                let tol = settings.cost_tolerance * old_cost;
                if actual <= tol && predicted <= tol {
                    break StopReason::Cost;
                }
                if small_step {
                    break StopReason::Step;
                }
            }
            _ => {
                if small_step {
                    break StopReason::Step;
                }
                mu *= nu;
                nu *= 2.0;
                if mu > 1e30 {
                    break StopReason::NoProgress;
                }
            }
        }
    };
    (
        Outcome {
            theta,
            point,
            damping: mu,
            iterations,
            stop,
        },
        ended,
    )
}
