//! The estimator's typed errors.

/// A parameter is out of range; names the field and what was wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("estimator parameter `{field}` {reason}")]
pub struct ParamError {
    pub field: &'static str,
    pub reason: String,
}

impl ParamError {
    pub fn new(field: &'static str, reason: impl Into<String>) -> ParamError {
        ParamError { field, reason: reason.into() }
    }
}

/// A sensor sample the estimator refused; it was counted and dropped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    #[error("{sensor} sample at {time} has a non-finite value")]
    NotFinite { sensor: &'static str, time: kestrel_proto::Time },
    #[error("{sensor} sample at {time} is not newer than the last one at {newest}")]
    OutOfOrder { sensor: &'static str, time: kestrel_proto::Time, newest: kestrel_proto::Time },
    #[error("{sensor} sample at {time} is older than the delayed fusion horizon at {horizon}")]
    BehindHorizon { sensor: &'static str, time: kestrel_proto::Time, horizon: kestrel_proto::Time },
    #[error("{sensor} sample at {time} is stamped too far after the newest IMU sample at {newest_imu}")]
    FromFuture { sensor: &'static str, time: kestrel_proto::Time, newest_imu: kestrel_proto::Time },
    #[error("IMU sample at {time} has an unusable interval of {dt_s} s")]
    BadInterval { time: kestrel_proto::Time, dt_s: f64 },
}
