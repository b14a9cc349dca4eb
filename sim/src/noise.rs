//! Measurement noise and the ADC: Gaussian noise per channel (a fraction of
//! the channel's RMS and/or an absolute level), clipping at the input range
//! and quantization.

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
    #[serde(default)]
    pub fraction: f64,
    #[serde(default)]
    pub absolute_force_n: f64,
    #[serde(default)]
    pub absolute_acceleration_m_s2: f64,
    #[serde(default)]
    pub adc: Option<AdcSettings>,
}

/// Analog-to-digital converter: values beyond the input range are clipped,
/// and, if `bits` is set, rounded to `2 * range / 2^bits` steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdcSettings {
    pub force_range_n: f64,
    pub acceleration_range_m_s2: f64,
    #[serde(default)]
    pub bits: Option<u32>,
}

impl NoiseSettings {
    pub fn check(&self) -> Result<(), SimError> {
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
    pub fn apply<R: rand::Rng + ?Sized>(&self, channel: &mut [f64], is_force: bool, rng: &mut R) {
        let sigma = self.sigma(rms(channel), is_force);
        for v in channel.iter_mut() {
            let z: f64 = rng.sample(StandardNormal);
            *v += sigma * z;
        }
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
