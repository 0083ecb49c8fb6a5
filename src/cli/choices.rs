//! The library's enums as command-line choices. The library knows nothing of clap: each
//! choice here mirrors one of its enums variant for variant, and converts both ways (so that
//! a variant added on either side and not on the other does not compile).

/// A mirror of a library enum that clap can offer, with conversions both ways.
macro_rules! choice {
    ($(#[$meta:meta])* $name:ident for $lib:path { $($(#[$vmeta:meta])* $variant:ident),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
        pub enum $name {
            $($(#[$vmeta])* $variant),+
        }

        impl From<$name> for $lib {
            fn from(choice: $name) -> Self {
                match choice {
                    $($name::$variant => <$lib>::$variant),+
                }
            }
        }

        impl From<$lib> for $name {
            fn from(value: $lib) -> Self {
                match value {
                    $(<$lib>::$variant => $name::$variant),+
                }
            }
        }
    };
}

choice! {
    /// Grade of an IMU.
    ImuGrade for hindsight::recon::config::ImuGrade {
        /// Ring-laser or fibre-optic navigation grade: 0.01 deg/h gyro, 25 ug accelerometer.
        Navigation,
        /// Between navigation and tactical: 0.1 deg/h, 100 ug.
        Intermediate,
        /// Tactical: 1 deg/h gyro, 100 ug accelerometer.
        Tactical,
        /// MEMS AHRS: 10 deg/h, 1 mg.
        Mems,
    }
}

choice! {
    /// Where the initial heading comes from.
    HeadingChoice for hindsight::recon::config::HeadingChoice {
        Auto,
        Gyrocompass,
        Magnetometer,
        Mission,
        Given,
    }
}

choice! {
    /// An attitude method.
    Method for hindsight::attitude::compare::Method {
        /// The accelerometer and magnetometer, sample by sample (Jeong et al. 2014, eq. 1-4).
        Raw,
        /// The Euler-angle EKF (Jeong et al. 2014, Table 1).
        Ekf,
        /// The Euler-angle UKF (Jeong et al. 2014, Table 2).
        Ukf,
        /// The complementary filter with PI rate-bias correction (Jeong et al. 2014, Table 3).
        Cf,
        /// hindsight's quaternion error-state filter with gyro-bias states.
        Mekf,
        /// The MEKF smoothed forward and backward over the whole log.
        MekfSmoothed,
    }
}

choice! {
    /// The base a configuration file is laid over.
    Preset for hindsight::attitude::config::Preset {
        /// hindsight's defaults (every covariance positive definite).
        Hindsight,
        /// The paper's EKF and UKF matrices exactly as printed (its Tables 6-7), for
        /// reproducing it.
        Seed001,
    }
}
