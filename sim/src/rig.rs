//! Test-rig realism: what lies between the shear model and the recorded
//! numbers besides the analyzer chain and the noise. Every effect is off
//! by default; with all of them off the simulation is exactly the bare one.
//!
//! Continuous-time effects are part of the [`Plant`], the linear system
//! from the force the exciter applies to the channels as the transducers
//! deliver them to the analyzer (before its anti-alias filter):
//! - [`ExtraMode`]: a mode that is not in the shear model (torsion,
//!   out-of-plane sway, a table mode) seen by the sensors and excited at
//!   the force point, as one more modal DOF in parallel;
//! - [`AccelerometerResonance`]: second-order dynamics of every
//!   accelerometer (the seismic mass on its piezo spring);
//! - [`ForceFilter`]: low-pass dynamics of the force, either of the force
//!   transducer only (the recorded force lags the applied one) or of the
//!   force itself (a soft hammer tip or a shaker stinger shaping the force
//!   that both the structure and the transducer see).
//!
//! Sampled effects act on each recorded channel ([`ChannelError`]): a gain
//! (calibration) error, a DC offset and a linear drift.
//!
//! Channels are named as in record files: `force`, then `acc1` ... `accN`
//! (floor 1 is the lowest).

use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::analyzer::butterworth;
use crate::error::{SimError, non_negative, positive};
use crate::model::Model;

/// Rig effects of a campaign (`[campaign.rig]`); all off by default.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigSettings {
    /// Modes outside the shear model (`[[campaign.rig.extra_modes]]`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_modes: Vec<ExtraMode>,
    /// Resonance of the accelerometers (all acceleration channels).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accelerometer: Option<AccelerometerResonance>,
    /// Low-pass dynamics of the force (transducer or tip).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_filter: Option<ForceFilter>,
    /// Gain, offset and drift of single channels (`[[campaign.rig.channels]]`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub channels: Vec<ChannelError>,
}

/// A mode that is not part of the shear model, added in parallel.
///
/// It is an uncoupled single-DOF oscillator in a modal coordinate `q`
/// (metres at unit participation):
/// `m q'' + 2 zeta w m q' + w^2 m q = phi_F f`, with `f` the force on the
/// structure, `w = 2 pi frequency_hz`, `m = modal_mass_kg`,
/// `phi_F = input_participation`. Accelerometer i additionally measures
/// `phi_i q''` (`phi_i = sensor_participation[i]`). Its accelerance from
/// the force to sensor i is therefore
/// `(phi_i phi_F / m) s^2 / (s^2 + 2 zeta w s + w^2)`, added to the shear
/// model's. The state space is augmented with `(q, q')`, so the
/// contribution is as exact as the rest of the response. It does not
/// change the model's M, K and damping (the truth of the shear model) and
/// is not orthogonalized against the shear modes: it is what a torsional
/// mode of a symmetric frame looks like to sensors off the centre line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtraMode {
    /// Free-text label for reports (for example `torsion`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub label: String,
    /// Undamped natural frequency, Hz.
    pub frequency_hz: f64,
    /// Modal damping ratio (0 <= zeta < 1).
    pub damping_ratio: f64,
    /// Modal mass, kg (at unit participation).
    pub modal_mass_kg: f64,
    /// Modal displacement at the force point per unit modal coordinate,
    /// m/m (dimensionless).
    pub input_participation: f64,
    /// Modal displacement at each accelerometer (floor 1 first) per unit
    /// modal coordinate, m/m; one entry per floor.
    pub sensor_participation: Vec<f64>,
}

/// Second-order dynamics of the accelerometers: each acceleration channel
/// records `w_s^2 / (s^2 + 2 zeta_s w_s s + w_s^2)` times the true
/// acceleration (unit gain at DC, `1 / (2 zeta_s)` at `resonance_hz`,
/// phase -90 degrees there).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelerometerResonance {
    /// Mounted resonance frequency `w_s / (2 pi)`, Hz.
    pub resonance_hz: f64,
    /// Damping ratio of the resonance (0 < zeta_s < 1; piezoelectric
    /// accelerometers are lightly damped, a few percent).
    pub damping_ratio: f64,
}

/// Which force signal the [`ForceFilter`] shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ForceFilterTarget {
    /// Only the recorded force: the structure is driven by the generated
    /// force (hammer half-sine or shaker signal), the force channel records
    /// it through the filter. Identification then sees a wrong input.
    #[default]
    Measured,
    /// The force itself: the structure and the force channel both see the
    /// filtered force (a soft tip lengthening and rounding the pulse). The
    /// input-output relation stays exact; only the spectrum changes.
    Applied,
}

/// Butterworth low-pass on the force (`[campaign.rig.force_filter]`), unit
/// DC gain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceFilter {
    /// -3 dB corner frequency, Hz.
    pub corner_hz: f64,
    /// Butterworth order, 1 to 8.
    #[serde(default = "default_force_filter_order")]
    pub order: usize,
    /// Which signal is filtered.
    #[serde(default)]
    pub applies_to: ForceFilterTarget,
}

fn default_force_filter_order() -> usize {
    2
}

/// Calibration and offset errors of one recorded channel: the record is
/// `gain * x + noise + offset + drift_per_s * t` (then the ADC), with `x`
/// the channel as the chain delivers it and `t` the time from the start of
/// the record, s. Noise set as a fraction of the channel's RMS is a
/// fraction of the RMS of `gain * x`; absolute noise does not depend on
/// the gain. Offsets and drifts come after the noise, so they do not raise
/// noise levels set as a fraction of the RMS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelError {
    /// `force` or `accK` (K = 1 for floor 1).
    pub channel: String,
    /// Recorded over true value (1 = calibrated).
    #[serde(default = "unit_gain")]
    pub gain: f64,
    /// DC offset in the channel's unit (N or m/s^2).
    #[serde(default)]
    pub offset: f64,
    /// Linear drift in the channel's unit per second.
    #[serde(default)]
    pub drift_per_s: f64,
}

fn unit_gain() -> f64 {
    1.0
}

/// Channel index of a record channel name: `force` is 0, `accK` is K.
pub fn channel_index(name: &str, floors: usize) -> Option<usize> {
    if name == "force" {
        return Some(0);
    }
    let k: usize = name.strip_prefix("acc")?.parse().ok()?;
    (1..=floors).contains(&k).then_some(k)
}

/// Gain, offset and drift of every channel (force first), resolved from
/// [`RigSettings::channels`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelErrors {
    /// Gain per channel.
    pub gain: Vec<f64>,
    /// Offset per channel, N or m/s^2.
    pub offset: Vec<f64>,
    /// Drift per channel, N/s or m/s^3.
    pub drift_per_s: Vec<f64>,
}

impl ChannelErrors {
    /// Applies the gain to a clean channel (before the noise).
    pub fn apply_gain(&self, channel: usize, x: &mut [f64]) {
        let g = self.gain[channel];
        if g != 1.0 {
            x.iter_mut().for_each(|v| *v *= g);
        }
    }

    /// Adds offset and drift (after the noise); `dt_s` is the sample interval.
    pub fn apply_offset(&self, channel: usize, x: &mut [f64], dt_s: f64) {
        let (o, d) = (self.offset[channel], self.drift_per_s[channel]);
        if o != 0.0 || d != 0.0 {
            for (k, v) in x.iter_mut().enumerate() {
                *v += o + d * (k as f64 * dt_s);
            }
        }
    }
}

impl RigSettings {
    /// True when no effect is set (the bare simulation).
    pub fn is_off(&self) -> bool {
        self == &RigSettings::default()
    }

    /// True when the continuous part (the plant) is the bare structure.
    pub fn plant_is_bare(&self) -> bool {
        self.extra_modes.is_empty() && self.accelerometer.is_none() && self.force_filter.is_none()
    }

    /// Checks the settings for a structure with `floors` floors; errors name
    /// the field as `rig.…`.
    pub fn check(&self, floors: usize) -> Result<(), SimError> {
        for (i, m) in self.extra_modes.iter().enumerate() {
            let at = format!("rig.extra_modes[{i}]");
            positive(&format!("{at}.frequency_hz"), m.frequency_hz)?;
            let zeta = non_negative(&format!("{at}.damping_ratio"), m.damping_ratio)?;
            if zeta >= 1.0 {
                return Err(SimError::invalid(
                    format!("{at}.damping_ratio"),
                    format!("must be below 1 (an underdamped mode), got {zeta}"),
                ));
            }
            positive(&format!("{at}.modal_mass_kg"), m.modal_mass_kg)?;
            if !m.input_participation.is_finite() {
                return Err(SimError::invalid(
                    format!("{at}.input_participation"),
                    "must be a finite number",
                ));
            }
            if m.sensor_participation.len() != floors {
                return Err(SimError::invalid(
                    format!("{at}.sensor_participation"),
                    format!(
                        "has {} entries, expected one per floor ({floors})",
                        m.sensor_participation.len()
                    ),
                ));
            }
            if let Some(j) = m.sensor_participation.iter().position(|v| !v.is_finite()) {
                return Err(SimError::invalid(
                    format!("{at}.sensor_participation[{j}]"),
                    "must be a finite number",
                ));
            }
        }
        if let Some(a) = &self.accelerometer {
            positive("rig.accelerometer.resonance_hz", a.resonance_hz)?;
            let zeta = positive("rig.accelerometer.damping_ratio", a.damping_ratio)?;
            if zeta >= 1.0 {
                return Err(SimError::invalid(
                    "rig.accelerometer.damping_ratio",
                    format!("must be below 1, got {zeta}"),
                ));
            }
        }
        if let Some(f) = &self.force_filter {
            positive("rig.force_filter.corner_hz", f.corner_hz)?;
            if !(1..=8).contains(&f.order) {
                return Err(SimError::invalid(
                    "rig.force_filter.order",
                    format!("must be between 1 and 8, got {}", f.order),
                ));
            }
        }
        let mut seen = vec![false; floors + 1];
        for (i, c) in self.channels.iter().enumerate() {
            let at = format!("rig.channels[{i}]");
            let idx = channel_index(&c.channel, floors).ok_or_else(|| {
                SimError::invalid(
                    format!("{at}.channel"),
                    format!(
                        "unknown channel {:?}; channels are \"force\" and \"acc1\" ..= \"acc{floors}\"",
                        c.channel
                    ),
                )
            })?;
            if seen[idx] {
                return Err(SimError::invalid(
                    format!("{at}.channel"),
                    format!("channel {:?} appears twice", c.channel),
                ));
            }
            seen[idx] = true;
            if !(c.gain.is_finite() && c.gain != 0.0) {
                return Err(SimError::invalid(
                    format!("{at}.gain"),
                    format!("must be a finite nonzero number, got {}", c.gain),
                ));
            }
            for (name, v) in [("offset", c.offset), ("drift_per_s", c.drift_per_s)] {
                if !v.is_finite() {
                    return Err(SimError::invalid(
                        format!("{at}.{name}"),
                        "must be a finite number",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Per-channel errors for `floors` floors, or `None` when no channel
    /// has any. Call after [`RigSettings::check`].
    pub fn channel_errors(&self, floors: usize) -> Option<ChannelErrors> {
        if self.channels.is_empty() {
            return None;
        }
        let mut e = ChannelErrors {
            gain: vec![1.0; floors + 1],
            offset: vec![0.0; floors + 1],
            drift_per_s: vec![0.0; floors + 1],
        };
        for c in &self.channels {
            let i = channel_index(&c.channel, floors).expect("checked channel name");
            e.gain[i] = c.gain;
            e.offset[i] = c.offset;
            e.drift_per_s[i] = c.drift_per_s;
        }
        Some(e)
    }
}

/// Continuous linear system from the force applied by the exciter (one
/// input) to the channels as delivered to the analyzer: output 0 the
/// force, output 1 + j the acceleration of floor j + 1.
/// `x' = a x + b u`, `y = c x + d u`.
#[derive(Debug, Clone, PartialEq)]
pub struct Plant {
    /// State matrix.
    pub a: DMatrix<f64>,
    /// Input column.
    pub b: DMatrix<f64>,
    /// Output matrix, one row per channel.
    pub c: DMatrix<f64>,
    /// Feedthrough column, one entry per channel.
    pub d: DMatrix<f64>,
    /// True when channel 0 is the applied force itself (`c` row 0 zero,
    /// `d[0] = 1`).
    pub direct_force: bool,
}

impl Plant {
    /// The structure alone: the force recorded as applied, accelerations
    /// as the model gives them (`a`, `b` are the model's state space for a
    /// force at `input_dof`, zero-based).
    pub fn bare(model: &Model, input_dof: usize) -> Plant {
        let sys = model.state_space(input_dof);
        let n = model.dofs();
        let ns = sys.a.nrows();
        let mut c = DMatrix::zeros(n + 1, ns);
        c.view_mut((1, 0), (n, ns)).copy_from(&sys.c);
        let mut d = DMatrix::zeros(n + 1, 1);
        d[(0, 0)] = 1.0;
        d.view_mut((1, 0), (n, 1)).copy_from(&sys.d);
        Plant {
            a: sys.a,
            b: sys.b,
            c,
            d,
            direct_force: true,
        }
    }

    /// The structure with the rig's continuous effects. With none set this
    /// is exactly [`Plant::bare`]. Call after [`RigSettings::check`].
    ///
    /// State order: structure `[x; x']`, extra modes `(q, q')` each, the
    /// force filter, then two accelerometer states per floor.
    pub fn new(model: &Model, input_dof: usize, rig: &RigSettings) -> Plant {
        if rig.plant_is_bare() {
            return Plant::bare(model, input_dof);
        }
        let n = model.dofs();
        let sys = model.state_space(input_dof);
        let xs = 0;
        let xe = 2 * n;
        let xf = xe + 2 * rig.extra_modes.len();
        let filter = rig
            .force_filter
            .as_ref()
            .map(|f| (butterworth(f.order, f.corner_hz), f.applies_to));
        let nf = filter.as_ref().map_or(0, |(f, _)| f.a.nrows());
        let xa = xf + nf;
        let na = if rig.accelerometer.is_some() {
            2 * n
        } else {
            0
        };
        let ns = xa + na;
        let mut a = DMatrix::zeros(ns, ns);
        let mut b = DMatrix::zeros(ns, 1);
        // Force on the structure: u_s = cu x + du u.
        let mut cu = DMatrix::zeros(1, ns);
        let mut du = 1.0;
        if let Some((f, target)) = &filter {
            a.view_mut((xf, xf), (nf, nf)).copy_from(&f.a);
            b.view_mut((xf, 0), (nf, 1)).copy_from(&f.b);
            if *target == ForceFilterTarget::Applied {
                cu.view_mut((0, xf), (1, nf)).copy_from(&f.c);
                du = 0.0;
            }
        }
        // Recorded force (before the accelerometer block, which does not
        // touch it).
        let mut c = DMatrix::zeros(n + 1, ns);
        let mut d = DMatrix::zeros(n + 1, 1);
        match &filter {
            Some((f, _)) => c.view_mut((0, xf), (1, nf)).copy_from(&f.c),
            None => d[(0, 0)] = 1.0,
        }
        // Anything driven by u_s gets `gain * (cu x + du u)`.
        let drive = |a: &mut DMatrix<f64>, b: &mut DMatrix<f64>, row: usize, gain: f64| {
            for j in 0..ns {
                a[(row, j)] += gain * cu[(0, j)];
            }
            b[(row, 0)] += gain * du;
        };
        a.view_mut((xs, xs), (2 * n, 2 * n)).copy_from(&sys.a);
        for r in 0..2 * n {
            drive(&mut a, &mut b, xs + r, sys.b[(r, 0)]);
        }
        // True accelerations: ca x + da u.
        let mut ca = DMatrix::zeros(n, ns);
        let mut da = DMatrix::zeros(n, 1);
        ca.view_mut((0, xs), (n, 2 * n)).copy_from(&sys.c);
        for i in 0..n {
            for j in 0..ns {
                ca[(i, j)] += sys.d[(i, 0)] * cu[(0, j)];
            }
            da[(i, 0)] = sys.d[(i, 0)] * du;
        }
        for (e, m) in rig.extra_modes.iter().enumerate() {
            let w = 2.0 * std::f64::consts::PI * m.frequency_hz;
            let (q, qd) = (xe + 2 * e, xe + 2 * e + 1);
            a[(q, qd)] = 1.0;
            a[(qd, q)] = -w * w;
            a[(qd, qd)] = -2.0 * m.damping_ratio * w;
            let g = m.input_participation / m.modal_mass_kg;
            drive(&mut a, &mut b, qd, g);
            // Sensor i adds phi_i q'' = phi_i (row qd of [a b]).
            for i in 0..n {
                let phi = m.sensor_participation[i];
                for j in 0..ns {
                    ca[(i, j)] += phi * a[(qd, j)];
                }
                da[(i, 0)] += phi * b[(qd, 0)];
            }
        }
        match &rig.accelerometer {
            None => {
                c.view_mut((1, 0), (n, ns)).copy_from(&ca);
                d.view_mut((1, 0), (n, 1)).copy_from(&da);
            }
            Some(acc) => {
                // w1' = w w2, w2' = -w w1 - 2 zeta w w2 + w a_true; record w1.
                let w = 2.0 * std::f64::consts::PI * acc.resonance_hz;
                for i in 0..n {
                    let (s1, s2) = (xa + 2 * i, xa + 2 * i + 1);
                    a[(s1, s2)] += w;
                    a[(s2, s1)] += -w;
                    a[(s2, s2)] += -2.0 * acc.damping_ratio * w;
                    for j in 0..ns {
                        a[(s2, j)] += w * ca[(i, j)];
                    }
                    b[(s2, 0)] += w * da[(i, 0)];
                    c[(1 + i, s1)] = 1.0;
                }
            }
        }
        Plant {
            a,
            b,
            c,
            d,
            direct_force: filter.is_none(),
        }
    }

    /// Number of states.
    pub fn states(&self) -> usize {
        self.a.nrows()
    }

    /// Number of channels (force plus one acceleration per floor).
    pub fn channels(&self) -> usize {
        self.c.nrows()
    }

    /// Frequency response `c (s I - a)^-1 b + d` at `s = i 2 pi f`: the
    /// channels per unit applied force (channel 0 dimensionless, the others
    /// accelerance in (m/s^2)/N).
    pub fn frf(&self, frequency_hz: f64) -> Vec<Complex64> {
        let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * frequency_hz);
        let ns = self.states();
        let to_c = |m: &DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
        let si = DMatrix::<Complex64>::identity(ns, ns) * s - to_c(&self.a);
        let x = si
            .lu()
            .solve(&to_c(&self.b))
            .expect("s I - A is regular on the imaginary axis for a damped plant");
        let y = to_c(&self.c) * x + to_c(&self.d);
        y.column(0).iter().copied().collect()
    }
}

/// The truth of the rig effects, for checking what identification does
/// with them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RigTruth {
    /// Modes outside the shear model.
    pub extra_modes: Vec<ExtraModeTruth>,
    /// Accelerometer resonance, if any.
    pub accelerometer: Option<AccelerometerResonance>,
    /// Force filter, if any.
    pub force_filter: Option<ForceFilter>,
    /// Gain, offset and drift of every channel (force first).
    pub channels: ChannelErrors,
}

/// One extra mode as the identification could see it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtraModeTruth {
    /// Label from the settings.
    pub label: String,
    /// Undamped natural frequency, Hz.
    pub frequency_hz: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// Continuous pole with positive imaginary part `[re, im]`, rad/s.
    pub pole_rad_s: [f64; 2],
    /// Accelerance modal constant per floor sensor,
    /// `phi_i phi_F / m`, 1/kg: the mode adds
    /// `r_i s^2 / (s^2 + 2 zeta w s + w^2)` to accelerance i (true
    /// acceleration, before any accelerometer resonance).
    pub modal_constants_per_kg: Vec<f64>,
}

impl RigTruth {
    /// The truth of `rig` on a structure of `floors` floors.
    pub fn new(rig: &RigSettings, floors: usize) -> RigTruth {
        let extra_modes = rig
            .extra_modes
            .iter()
            .map(|m| {
                let w = 2.0 * std::f64::consts::PI * m.frequency_hz;
                let z = m.damping_ratio;
                ExtraModeTruth {
                    label: m.label.clone(),
                    frequency_hz: m.frequency_hz,
                    damping_ratio: z,
                    pole_rad_s: [-z * w, w * (1.0 - z * z).sqrt()],
                    modal_constants_per_kg: m
                        .sensor_participation
                        .iter()
                        .map(|p| p * m.input_participation / m.modal_mass_kg)
                        .collect(),
                }
            })
            .collect();
        RigTruth {
            extra_modes,
            accelerometer: rig.accelerometer.clone(),
            force_filter: rig.force_filter.clone(),
            channels: rig.channel_errors(floors).unwrap_or_else(|| ChannelErrors {
                gain: vec![1.0; floors + 1],
                offset: vec![0.0; floors + 1],
                drift_per_s: vec![0.0; floors + 1],
            }),
        }
    }
}
