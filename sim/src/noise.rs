//! Measurement noise and the ADC: Gaussian noise per channel (a fraction of
//! the channel's RMS and/or an absolute level), white and optionally
//! coloured, clipping at the input range and quantization.

use rand::RngExt;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, non_negative, positive};

/// Noise on every channel. The standard deviation of channel c in a hit is
/// `sqrt((fraction * rms_c)^2 + absolute_c^2)`, with `rms_c` the RMS of the
/// noise-free channel over that hit's record.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSettings {
    /// White-noise standard deviation as a fraction of the clean channel's RMS.
    #[serde(default)]
    pub fraction: f64,
    /// Absolute white-noise standard deviation on the force channel, N.
    #[serde(default)]
    pub absolute_force_n: f64,
    /// Absolute white-noise standard deviation on the acceleration channels, m/s^2.
    #[serde(default)]
    pub absolute_acceleration_m_s2: f64,
    /// The ADC's range and resolution; none by default.
    #[serde(default)]
    pub adc: Option<AdcSettings>,
    /// Coloured (correlated) Gaussian noise added to the white noise
    /// (`[campaign.noise.coloured]`); off by default.
    #[serde(default, alias = "colored", skip_serializing_if = "Option::is_none")]
    pub coloured: Option<ColouredNoise>,
}

/// Gaussian noise with a non-flat spectrum, added on every channel on top
/// of the white noise. Its standard deviation on channel c is
/// `sqrt((fraction * rms_c)^2 + absolute_c^2)` like the white noise's
/// (`rms_c` the RMS of the noise-free channel); the spectrum sets how that
/// variance is spread over frequency. It is drawn from its own random
/// stream, so switching it on leaves the white noise unchanged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColouredNoise {
    /// Spectrum shape.
    pub spectrum: NoiseSpectrum,
    /// Standard deviation as a fraction of the clean channel's RMS.
    #[serde(default)]
    pub fraction: f64,
    /// Absolute standard deviation on the force channel, N.
    #[serde(default)]
    pub absolute_force_n: f64,
    /// Absolute standard deviation on the acceleration channels, m/s^2.
    #[serde(default)]
    pub absolute_acceleration_m_s2: f64,
}

/// Spectrum of [`ColouredNoise`], for records sampled every `dt`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum NoiseSpectrum {
    /// First-order low-pass filtered white noise (an Ornstein-Uhlenbeck
    /// process sampled exactly): `x[k+1] = a x[k] + sqrt(1 - a^2) z[k+1]`,
    /// `a = exp(-2 pi corner_hz dt)`, started in its stationary state.
    /// Spectrum `(1 - a^2) / |1 - a e^{-i w dt}|^2`: flat below the
    /// corner, falling 20 dB per decade above it (slope -2 of the power in
    /// log-log) until near the Nyquist frequency.
    LowPass {
        /// Corner frequency, Hz.
        corner_hz: f64,
    },
    /// 1/f ("pink") noise from `min_frequency_hz` up: the mean of
    /// unit-variance low-pass processes as above with corners
    /// `min_frequency_hz * 10^(j/3)`, j = -3, -2, ... up to the Nyquist
    /// frequency (three per decade, from a decade below the 1/f range so
    /// that it holds down to `min_frequency_hz`). The exact spectrum (sum
    /// of the components') stays within 0.5 dB peak to peak of a 1/f line
    /// from `min_frequency_hz` to a quarter of the Nyquist frequency and
    /// within 0.9 dB to half of it (1.7 dB near the Nyquist frequency,
    /// where the sampled components alias); log-log slope -0.99 +- 0.02.
    /// It flattens below `min_frequency_hz / 10`.
    Pink {
        /// Lower end of the 1/f range, Hz; default the inverse record
        /// length.
        #[serde(default)]
        min_frequency_hz: Option<f64>,
    },
}

impl ColouredNoise {
    /// Checks the settings; errors name the field as `noise.coloured.…`.
    pub fn check(&self) -> Result<(), SimError> {
        non_negative("noise.coloured.fraction", self.fraction)?;
        non_negative("noise.coloured.absolute_force_n", self.absolute_force_n)?;
        non_negative(
            "noise.coloured.absolute_acceleration_m_s2",
            self.absolute_acceleration_m_s2,
        )?;
        match &self.spectrum {
            NoiseSpectrum::LowPass { corner_hz } => {
                positive("noise.coloured.spectrum.corner_hz", *corner_hz)?;
            }
            NoiseSpectrum::Pink { min_frequency_hz } => {
                if let Some(f) = min_frequency_hz {
                    positive("noise.coloured.spectrum.min_frequency_hz", *f)?;
                }
            }
        }
        Ok(())
    }

    /// Standard deviation on a channel with the given clean RMS.
    pub fn sigma(&self, rms: f64, is_force: bool) -> f64 {
        let abs = if is_force {
            self.absolute_force_n
        } else {
            self.absolute_acceleration_m_s2
        };
        (self.fraction * rms).hypot(abs)
    }

    /// Corner frequencies of the unit-variance low-pass components whose
    /// mean is the noise, for records of `len` samples every `dt_s`.
    pub fn corners_hz(&self, dt_s: f64, len: usize) -> Vec<f64> {
        match &self.spectrum {
            NoiseSpectrum::LowPass { corner_hz } => vec![*corner_hz],
            NoiseSpectrum::Pink { min_frequency_hz } => {
                let lo = min_frequency_hz.unwrap_or(1.0 / (len.max(1) as f64 * dt_s));
                let nyquist = 0.5 / dt_s;
                let mut f = Vec::new();
                let mut j = -3;
                loop {
                    let c = lo * 10f64.powf(j as f64 / 3.0);
                    if c > nyquist && !f.is_empty() {
                        break;
                    }
                    f.push(c);
                    j += 1;
                }
                f
            }
        }
    }

    /// Unit-variance noise of `len` samples every `dt_s`.
    pub fn unit_samples<R: rand::Rng + ?Sized>(
        &self,
        dt_s: f64,
        len: usize,
        rng: &mut R,
    ) -> Vec<f64> {
        let corners = self.corners_hz(dt_s, len);
        let mut sum = vec![0.0; len];
        for &fc in &corners {
            let a = (-2.0 * std::f64::consts::PI * fc * dt_s).exp();
            let b = (1.0 - a * a).sqrt();
            let mut x: f64 = rng.sample(StandardNormal);
            for (k, v) in sum.iter_mut().enumerate() {
                if k > 0 {
                    let z: f64 = rng.sample(StandardNormal);
                    x = a * x + b * z;
                }
                *v += x;
            }
        }
        // Independent components: the mean of J has variance 1 / J.
        let scale = 1.0 / (corners.len() as f64).sqrt();
        sum.iter_mut().for_each(|v| *v *= scale);
        sum
    }

    /// Adds the noise to a channel whose clean RMS is `clean_rms`.
    pub fn add<R: rand::Rng + ?Sized>(
        &self,
        channel: &mut [f64],
        clean_rms: f64,
        is_force: bool,
        dt_s: f64,
        rng: &mut R,
    ) {
        let sigma = self.sigma(clean_rms, is_force);
        let x = self.unit_samples(dt_s, channel.len(), rng);
        for (v, n) in channel.iter_mut().zip(x) {
            *v += sigma * n;
        }
    }
}

/// Analog-to-digital converter: values beyond the input range are clipped,
/// and, if `bits` is set, rounded to `2 * range / 2^bits` steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdcSettings {
    /// Input range of the force channel, +- N.
    pub force_range_n: f64,
    /// Input range of the acceleration channels, +- m/s^2.
    pub acceleration_range_m_s2: f64,
    /// Resolution, bits; none: no quantization.
    #[serde(default)]
    pub bits: Option<u32>,
}

impl NoiseSettings {
    /// Checks the settings; errors name the field as `noise.…`.
    pub fn check(&self) -> Result<(), SimError> {
        if let Some(c) = &self.coloured {
            c.check()?;
        }
        non_negative("noise.fraction", self.fraction)?;
        non_negative("noise.absolute_force_n", self.absolute_force_n)?;
        non_negative(
            "noise.absolute_acceleration_m_s2",
            self.absolute_acceleration_m_s2,
        )?;
        if let Some(adc) = &self.adc {
            positive("noise.adc.force_range_n", adc.force_range_n)?;
            positive(
                "noise.adc.acceleration_range_m_s2",
                adc.acceleration_range_m_s2,
            )?;
            if let Some(bits) = adc.bits
                && !(2..=32).contains(&bits)
            {
                return Err(SimError::invalid(
                    "noise.adc.bits",
                    format!("must be between 2 and 32, got {bits}"),
                ));
            }
        }
        Ok(())
    }

    /// Standard deviation of the noise on a channel with the given clean RMS.
    pub fn sigma(&self, rms: f64, is_force: bool) -> f64 {
        let abs = if is_force {
            self.absolute_force_n
        } else {
            self.absolute_acceleration_m_s2
        };
        (self.fraction * rms).hypot(abs)
    }

    /// Adds noise to one channel, then applies the ADC. One standard normal
    /// draw per sample is always consumed, so the random stream (and hence
    /// every later channel and hit) does not depend on the noise level.
    /// (White noise only: coloured noise needs the sample interval, see
    /// [`ColouredNoise::add`].)
    pub fn apply<R: rand::Rng + ?Sized>(&self, channel: &mut [f64], is_force: bool, rng: &mut R) {
        let sigma = self.sigma(rms(channel), is_force);
        add_white(channel, sigma, rng);
        self.digitize(channel, is_force);
    }

    /// The ADC: clipping at the input range and quantization, if set.
    pub fn digitize(&self, channel: &mut [f64], is_force: bool) {
        if let Some(adc) = &self.adc {
            let range = if is_force {
                adc.force_range_n
            } else {
                adc.acceleration_range_m_s2
            };
            let step = adc.bits.map(|b| 2.0 * range / 2f64.powi(b as i32));
            for v in channel.iter_mut() {
                *v = v.clamp(-range, range);
                if let Some(q) = step {
                    *v = (*v / q).round() * q;
                }
            }
        }
    }
}

/// Adds white Gaussian noise of standard deviation `sigma`, one standard
/// normal draw per sample whatever `sigma`.
pub fn add_white<R: rand::Rng + ?Sized>(channel: &mut [f64], sigma: f64, rng: &mut R) {
    for v in channel.iter_mut() {
        let z: f64 = rng.sample(StandardNormal);
        *v += sigma * z;
    }
}

/// Root mean square of a record.
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;

    #[test]
    fn clipping_and_quantization() {
        let noise = NoiseSettings {
            adc: Some(AdcSettings {
                force_range_n: 1.0,
                acceleration_range_m_s2: 2.0,
                bits: Some(3),
            }),
            ..Default::default()
        };
        let mut x = vec![-5.0, -0.3, 0.1, 0.26, 1.9, 7.0];
        noise.apply(&mut x, false, &mut ChaCha8Rng::seed_from_u64(1));
        // Range 2 and 3 bits: step 4 / 8 = 0.5; clipped to +-2 first.
        assert_eq!(x, vec![-2.0, -0.5, 0.0, 0.5, 2.0, 2.0]);
    }

    #[test]
    fn bad_settings_name_the_field() {
        let n = NoiseSettings {
            fraction: -0.1,
            ..Default::default()
        };
        assert_eq!(
            n.check().unwrap_err().to_string(),
            "noise.fraction: must be a finite number >= 0, got -0.1"
        );
    }
}
