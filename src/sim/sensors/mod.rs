//! Sensor error models. Each takes the truth and a seeded random generator of its own, and
//! returns the contract message a real sensor of that grade would log.
//!
//! Every random draw comes from a `ChaCha8Rng` seeded by the scenario seed and a fixed stream
//! number per sensor ([`rng_for`]), so a log depends only on (scenario, seed): not on threads,
//! not on which other sensors are enabled.

pub mod dvl;
pub mod imu;
pub mod lbl;
pub mod mag;
pub mod scalar;
pub mod usbl;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Stream numbers: one per sensor, fixed forever (changing one changes every log).
pub mod stream {
    pub const GYRO: u64 = 1;
    pub const ACCEL: u64 = 2;
    pub const MAG: u64 = 3;
    pub const DVL: u64 = 4;
    pub const EML: u64 = 5;
    pub const DEPTH: u64 = 6;
    pub const ALTIMETER: u64 = 7;
    pub const RPM: u64 = 8;
    pub const GNSS: u64 = 9;
    pub const FIX: u64 = 10;
    pub const AHRS: u64 = 11;
    pub const HOST: u64 = 12;
    pub const MOTION: u64 = 13;
    pub const USBL: u64 = 14;
    pub const LBL: u64 = 15;
}

/// The generator of one sensor in one run.
pub fn rng_for(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// A standard normal draw.
pub fn normal(rng: &mut ChaCha8Rng) -> f64 {
    use rand_distr::Distribution;
    rand_distr::StandardNormal.sample(rng)
}
