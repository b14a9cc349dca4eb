//! Test support shared by the frameid crates: the one builder of the analytic
//! shear frames the tests identify, simulate and render.
//!
//! A [`ShearFrame`] is a mass, a stiffness and a damping matrix. It is built
//! from matrices ([`ShearFrame::new`], [`ShearFrame::undamped`]) or from
//! lumped floor masses and storey stiffnesses ([`ShearFrame::lumped`]);
//! damping is set with Rayleigh coefficients ([`ShearFrame::rayleigh`]) or
//! ratios ([`ShearFrame::rayleigh_ratio`]) and storey dashpots are added on
//! top ([`ShearFrame::storey_dashpot`]). From it come the continuous state
//! space with acceleration outputs ([`ShearFrame::continuous`]), its exact
//! zero-order-hold discretization ([`zoh`]), the modes and the accelerances.
//! [`paper_case1`] and [`paper_case2`] are the paper's identified frames.
//!
//! Everything here is computed with plain nalgebra, independently of the
//! crates under test: the crate depends on nalgebra only, so that `ident`'s
//! own unit tests can use it (a dependency on `ident` or `sim` would make
//! their types distinct from the crate under test's).
//!
//! # Conventions
//!
//! As in the rest of frameid: SI units (kg, N/m, N s/m, Hz); DOF `i`
//! (0-based) is the lateral displacement of floor `i + 1`, floor 1 the
//! lowest; storey `s` (1-based) joins floor `s - 1` (the ground for
//! `s = 1`) to floor `s`. The damping matrix is `damping`; `c` is an output
//! matrix. Modes are in ascending frequency.
//!
//! # Example
//!
//! ```
//! // Two floors of 1 kg on storeys of 1000 and 500 N/m, 1 % damping at both modes.
//! let frame = testkit::ShearFrame::lumped(&[1.0, 1.0], &[1000.0, 500.0]);
//! let f = frame.undamped_frequencies_hz();
//! let frame = frame.rayleigh_ratio(0.01, f[0], f[1]);
//! for (frequency_hz, ratio) in frame.modes() {
//!     assert!((ratio - 0.01).abs() < 1e-12);
//!     assert!(f.iter().any(|&g| (g / frequency_hz - 1.0).abs() < 1e-12));
//! }
//! let (a, b, c, d) = frame.continuous(0);
//! let (ad, bd) = testkit::zoh(&a, &b, 1.0 / 64.0);
//! assert_eq!((ad.nrows(), bd.ncols(), c.nrows(), d.ncols()), (4, 1, 2, 1));
//! ```

#![deny(missing_docs)]

use std::f64::consts::PI;

use nalgebra::{Cholesky, Complex, DMatrix, DVector, SymmetricEigen};

/// Complex numbers (nalgebra's re-export of `num_complex::Complex<f64>`).
pub type C64 = Complex<f64>;

/// The paper's case 1 Rayleigh coefficients `(alpha 1/s, beta s)` (eq. 41-42).
pub const PAPER_CASE1_RAYLEIGH: (f64, f64) = (0.1755, 3.2283e-5);

/// The paper's case 2 Rayleigh coefficients `(alpha 1/s, beta s)` (eq. 58-59).
pub const PAPER_CASE2_RAYLEIGH: (f64, f64) = (0.1752, 3.4355e-5);

/// Mass (kg), stiffness (N/m) and damping (N s/m) matrices of a shear frame,
/// square and of one size.
#[derive(Debug, Clone, PartialEq)]
pub struct ShearFrame {
    /// Mass matrix, kg.
    pub mass: DMatrix<f64>,
    /// Stiffness matrix, N/m.
    pub stiffness: DMatrix<f64>,
    /// Damping matrix, N s/m.
    pub damping: DMatrix<f64>,
}

/// The paper's case 1 (Guida, Nilvetti, Pappalardo 2011): the identified
/// mass (eq. 44) and stiffness (eq. 45) of the bare two-storey frame with its
/// Rayleigh damping `0.1755 M + 3.2283e-5 K` (eq. 41-42, 47). Modes at 2.725
/// and 9.154 Hz, damping ratios 0.54 % and 0.25 %.
pub fn paper_case1() -> ShearFrame {
    let mass = DMatrix::from_row_slice(2, 2, &[0.2913, 0.0153, 0.0153, 0.3387]);
    let stiffness = DMatrix::from_row_slice(2, 2, &[630.44, -425.83, -425.83, 439.01]);
    let (alpha, beta) = PAPER_CASE1_RAYLEIGH;
    ShearFrame::undamped(mass, stiffness).rayleigh(alpha, beta)
}

/// The paper's case 2 (added mass on floor 1): the identified mass (eq. 61),
/// the stiffness implied by eq. 64 (the printed eq. 62 repeats case 1's, a
/// misprint) and the Rayleigh damping of eq. 58-59; as
/// `scenarios/paper-case2.toml`. Modes at 1.876 and 6.958 Hz.
pub fn paper_case2() -> ShearFrame {
    let mass = DMatrix::from_row_slice(2, 2, &[1.3771, 0.0119, 0.0119, 0.5566]);
    let stiffness = DMatrix::from_row_slice(2, 2, &[949.8, -709.8, -709.8, 744.7]);
    let (alpha, beta) = PAPER_CASE2_RAYLEIGH;
    ShearFrame::undamped(mass, stiffness).rayleigh(alpha, beta)
}

/// Matrix of springs (or dashpots) in a chain from the ground: element `i`
/// joins DOF `i - 1` (the ground for `i = 0`) to DOF `i`. For storey
/// stiffnesses this is the stiffness matrix of the shear frame.
pub fn chain_matrix(elements: &[f64]) -> DMatrix<f64> {
    let n = elements.len();
    let mut k = DMatrix::zeros(n, n);
    for (i, &ki) in elements.iter().enumerate() {
        k[(i, i)] += ki;
        if i > 0 {
            k[(i - 1, i - 1)] += ki;
            k[(i - 1, i)] -= ki;
            k[(i, i - 1)] -= ki;
        }
    }
    k
}

/// Rayleigh coefficients `(alpha 1/s, beta s)` that give the damping ratio
/// `ratio` at both `f1_hz` and `f2_hz`: with `w = 2 pi f`,
/// `ratio = alpha / (2 w) + beta w / 2` at both, so
/// `beta = 2 ratio / (w1 + w2)` and `alpha = beta w1 w2`.
pub fn rayleigh_for_ratio(ratio: f64, f1_hz: f64, f2_hz: f64) -> (f64, f64) {
    let (w1, w2) = (2.0 * PI * f1_hz, 2.0 * PI * f2_hz);
    let beta = 2.0 * ratio / (w1 + w2);
    (beta * w1 * w2, beta)
}

/// Exact zero-order-hold discretization `(Ad, Bd)` of `x' = a x + b u` over
/// `dt_s` seconds, from the matrix exponential of `[[a, b], [0, 0]] dt_s`
/// (`b` may have several columns).
pub fn zoh(a: &DMatrix<f64>, b: &DMatrix<f64>, dt_s: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, r) = b.shape();
    assert_eq!(a.shape(), (n, n), "zoh: a must be square with b's rows");
    let mut aug = DMatrix::zeros(n + r, n + r);
    aug.view_mut((0, 0), (n, n)).copy_from(a);
    aug.view_mut((0, n), (n, r)).copy_from(b);
    let e = (aug * dt_s).exp();
    (
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, r)).into_owned(),
    )
}

impl ShearFrame {
    /// A frame from its three matrices. Panics if they are not square and of
    /// one size (a test's own mistake).
    pub fn new(mass: DMatrix<f64>, stiffness: DMatrix<f64>, damping: DMatrix<f64>) -> Self {
        let n = mass.nrows();
        for (name, m) in [
            ("mass", &mass),
            ("stiffness", &stiffness),
            ("damping", &damping),
        ] {
            assert_eq!(m.shape(), (n, n), "ShearFrame: {name} must be {n} x {n}");
        }
        ShearFrame {
            mass,
            stiffness,
            damping,
        }
    }

    /// A frame without damping.
    pub fn undamped(mass: DMatrix<f64>, stiffness: DMatrix<f64>) -> Self {
        let n = mass.nrows();
        Self::new(mass, stiffness, DMatrix::zeros(n, n))
    }

    /// Lumped floor masses (kg, floor 1 first) on storeys of the given
    /// lateral stiffnesses (N/m, storey 1 first): diagonal mass,
    /// [`chain_matrix`] stiffness, no damping.
    pub fn lumped(masses_kg: &[f64], storey_stiffnesses_n_per_m: &[f64]) -> Self {
        assert_eq!(
            masses_kg.len(),
            storey_stiffnesses_n_per_m.len(),
            "ShearFrame::lumped: one storey per floor"
        );
        Self::undamped(
            DMatrix::from_diagonal(&DVector::from_column_slice(masses_kg)),
            chain_matrix(storey_stiffnesses_n_per_m),
        )
    }

    /// Replaces the damping with `alpha M + beta K` (alpha in 1/s, beta in s).
    pub fn rayleigh(mut self, alpha: f64, beta: f64) -> Self {
        self.damping = &self.mass * alpha + &self.stiffness * beta;
        self
    }

    /// Replaces the damping with the Rayleigh damping that gives `ratio` at
    /// `f1_hz` and `f2_hz` ([`rayleigh_for_ratio`]).
    pub fn rayleigh_ratio(self, ratio: f64, f1_hz: f64, f2_hz: f64) -> Self {
        let (alpha, beta) = rayleigh_for_ratio(ratio, f1_hz, f2_hz);
        self.rayleigh(alpha, beta)
    }

    /// Adds a viscous dashpot of `coefficient_ns_per_m` across storey
    /// `storey` (1-based: storey 1 joins the ground to floor 1, storey `s`
    /// floor `s - 1` to floor `s`). The damping is then not proportional.
    pub fn storey_dashpot(mut self, storey: usize, coefficient_ns_per_m: f64) -> Self {
        let n = self.dofs();
        assert!(
            (1..=n).contains(&storey),
            "storey {storey} does not exist; storeys are numbered 1..={n}"
        );
        let upper = storey - 1;
        self.damping[(upper, upper)] += coefficient_ns_per_m;
        if storey > 1 {
            let lower = storey - 2;
            self.damping[(lower, lower)] += coefficient_ns_per_m;
            self.damping[(lower, upper)] -= coefficient_ns_per_m;
            self.damping[(upper, lower)] -= coefficient_ns_per_m;
        }
        self
    }

    /// Degrees of freedom (floors).
    pub fn dofs(&self) -> usize {
        self.mass.nrows()
    }

    /// The three matrices `(mass, stiffness, damping)`.
    pub fn into_parts(self) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        (self.mass, self.stiffness, self.damping)
    }

    /// Undamped natural frequencies (Hz), ascending: square roots of the
    /// eigenvalues of `M^-1 K` over `2 pi`.
    pub fn undamped_frequencies_hz(&self) -> Vec<f64> {
        let mi = self.mass.clone().try_inverse().expect("invertible mass");
        let mut f: Vec<f64> = (mi * &self.stiffness)
            .complex_eigenvalues()
            .iter()
            .map(|l| l.re.sqrt() / (2.0 * PI))
            .collect();
        f.sort_by(f64::total_cmp);
        f
    }

    /// Undamped modes of `K phi = w^2 M phi`, ascending: the natural
    /// frequency (Hz) and the real shape scaled so that its largest-magnitude
    /// component is 1 (by the symmetric eigenproblem of `L^-1 K L^-T`,
    /// `M = L L^T`).
    pub fn undamped_modes(&self) -> Vec<(f64, DVector<f64>)> {
        let l = Cholesky::new(self.mass.clone())
            .expect("positive definite mass")
            .l();
        let l_inv = l.try_inverse().expect("invertible Cholesky factor");
        let sym = &l_inv * &self.stiffness * l_inv.transpose();
        let eig = SymmetricEigen::new((&sym + sym.transpose()) * 0.5);
        let mut modes: Vec<(f64, DVector<f64>)> = (0..self.dofs())
            .map(|j| {
                let phi = l_inv.transpose() * eig.eigenvectors.column(j);
                let pivot = phi[phi.iamax()];
                (eig.eigenvalues[j].sqrt() / (2.0 * PI), phi / pivot)
            })
            .collect();
        modes.sort_by(|a, b| a.0.total_cmp(&b.0));
        modes
    }

    /// Continuous state space `(A, B, C, D)` with state `[x; x']`, a force at
    /// `input_dof` (0-based) and the absolute accelerations of every DOF as
    /// outputs: `A = [[0, I], [-M^-1 K, -M^-1 damping]]`,
    /// `B = [0; M^-1 e_input]`, `C = [-M^-1 K, -M^-1 damping]`,
    /// `D = M^-1 e_input`.
    pub fn continuous(
        &self,
        input_dof: usize,
    ) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let n = self.dofs();
        assert!(input_dof < n, "input DOF {input_dof} of {n}");
        let mi = self.mass.clone().try_inverse().expect("invertible mass");
        let mik = -(&mi * &self.stiffness);
        let mir = -(&mi * &self.damping);
        let mut a = DMatrix::zeros(2 * n, 2 * n);
        a.view_mut((0, n), (n, n)).fill_with_identity();
        a.view_mut((n, 0), (n, n)).copy_from(&mik);
        a.view_mut((n, n), (n, n)).copy_from(&mir);
        let mut b = DMatrix::zeros(2 * n, 1);
        b.view_mut((n, 0), (n, 1)).copy_from(&mi.column(input_dof));
        let mut c = DMatrix::zeros(n, 2 * n);
        c.view_mut((0, 0), (n, n)).copy_from(&mik);
        c.view_mut((0, n), (n, n)).copy_from(&mir);
        let d = mi.columns(input_dof, 1).into_owned();
        (a, b, c, d)
    }

    /// Natural frequencies (Hz, `|lambda| / 2 pi`) and damping ratios
    /// (`-Re(lambda) / |lambda|`) of the underdamped modes, ascending, from
    /// nalgebra's eigenvalues of the continuous `A`.
    pub fn modes(&self) -> Vec<(f64, f64)> {
        let (a, ..) = self.continuous(0);
        let mut out: Vec<(f64, f64)> = a
            .complex_eigenvalues()
            .iter()
            .filter(|l| l.im > 0.0)
            .map(|l| (l.norm() / (2.0 * PI), -l.re / l.norm()))
            .collect();
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }

    /// Accelerance of every floor (m/s^2 per N) to a force at `input_dof` at
    /// `frequency_hz`: `-w^2 (K - w^2 M + i w damping)^-1 e_input`, time
    /// convention `e^{+i w t}`.
    pub fn accelerance(&self, input_dof: usize, frequency_hz: f64) -> Vec<C64> {
        let w = 2.0 * PI * frequency_hz;
        let n = self.dofs();
        let z = DMatrix::from_fn(n, n, |i, j| {
            C64::new(
                self.stiffness[(i, j)] - w * w * self.mass[(i, j)],
                w * self.damping[(i, j)],
            )
        });
        let mut e = DMatrix::<C64>::zeros(n, 1);
        e[(input_dof, 0)] = C64::new(1.0, 0.0);
        let x = z
            .lu()
            .solve(&e)
            .expect("no undamped resonance at this frequency");
        x.iter().map(|v| v * (-w * w)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Undamped frequencies of a 2-DOF frame from the closed-form roots of
    /// `det(K - w^2 M) = 0`.
    fn closed_form_hz(f: &ShearFrame) -> [f64; 2] {
        let (m, k) = (&f.mass, &f.stiffness);
        let a = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
        let b = -(k[(0, 0)] * m[(1, 1)] + k[(1, 1)] * m[(0, 0)]
            - k[(0, 1)] * m[(1, 0)]
            - k[(1, 0)] * m[(0, 1)]);
        let c = k[(0, 0)] * k[(1, 1)] - k[(0, 1)] * k[(1, 0)];
        let disc = (b * b - 4.0 * a * c).sqrt();
        [(-b - disc) / (2.0 * a), (-b + disc) / (2.0 * a)].map(|w2| w2.sqrt() / (2.0 * PI))
    }

    #[test]
    fn paper_frames_have_the_published_modes() {
        // Frequencies as the scenario files state them (4 digits): 5e-4 relative.
        for (frame, want) in [
            (paper_case1(), [2.725, 9.154]),
            (paper_case2(), [1.876, 6.958]),
        ] {
            let exact = closed_form_hz(&frame);
            let by_eig = frame.undamped_frequencies_hz();
            let by_modes: Vec<f64> = frame.undamped_modes().iter().map(|m| m.0).collect();
            let damped: Vec<f64> = frame.modes().iter().map(|m| m.0).collect();
            for j in 0..2 {
                assert!((exact[j] / want[j] - 1.0).abs() < 5e-4, "{exact:?}");
                // Three eigen-solvers against the quadratic formula: round-off (1e-12).
                assert!((by_eig[j] / exact[j] - 1.0).abs() < 1e-12);
                assert!((by_modes[j] / exact[j] - 1.0).abs() < 1e-12);
                // Rayleigh damping is proportional: |lambda| is the undamped frequency.
                assert!((damped[j] / exact[j] - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn rayleigh_ratios_and_dashpots() {
        let frame = ShearFrame::lumped(&[1.0, 0.9, 0.8], &[1000.0, 900.0, 800.0]);
        let f = frame.undamped_frequencies_hz();
        let damped = frame.clone().rayleigh_ratio(0.005, f[0], f[2]);
        let modes = damped.modes();
        // The two target modes get exactly the ratio (round-off, 1e-12); the middle one
        // less (Rayleigh damping dips between its anchors).
        assert!((modes[0].1 - 0.005).abs() < 1e-12 && (modes[2].1 - 0.005).abs() < 1e-12);
        assert!(modes[1].1 < 0.005);
        // A dashpot across storey 2 joins floors 1 and 2 (DOFs 0 and 1); across storey 1
        // it joins floor 1 to the ground.
        let d = frame.storey_dashpot(2, 0.3).storey_dashpot(1, 0.1).damping;
        let want = DMatrix::from_row_slice(3, 3, &[0.4, -0.3, 0.0, -0.3, 0.3, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(d, want);
    }

    #[test]
    fn accelerance_matches_the_state_space_and_the_hold_is_exact_for_steps() {
        let frame = paper_case1();
        let (a, b, c, d) = frame.continuous(0);
        // H(i w) = C (i w I - A)^-1 B + D against the second-order formula.
        let f_hz = 5.0;
        let w = 2.0 * PI * f_hz;
        let n = a.nrows();
        let s = DMatrix::from_fn(n, n, |i, j| {
            C64::new(-a[(i, j)], if i == j { w } else { 0.0 })
        });
        let x = s.lu().solve(&b.map(|v| C64::new(v, 0.0))).unwrap();
        let h = c.map(|v| C64::new(v, 0.0)) * x + d.map(|v| C64::new(v, 0.0));
        for (got, want) in frame.accelerance(0, f_hz).iter().zip(h.iter()) {
            // Two solves of well-conditioned 2x2 and 4x4 systems: round-off (1e-12).
            assert!((got - want).norm() < 1e-12 * want.norm());
        }
        // A held unit force from rest: the discrete response after k steps equals the
        // continuous step response, x(t) = A^-1 (e^{A t} - I) B.
        let dt = 1.0 / 64.0;
        let (ad, bd) = zoh(&a, &b, dt);
        let mut xk = DMatrix::zeros(n, 1);
        for _ in 0..10 {
            xk = &ad * xk + &bd;
        }
        let exact = a.clone().try_inverse().unwrap()
            * ((&a * (10.0 * dt)).exp() - DMatrix::identity(n, n))
            * &b;
        // Ten steps of products of O(1) matrices: round-off (1e-12 of the state).
        assert!((xk - &exact).norm() < 1e-12 * exact.norm());
    }
}
