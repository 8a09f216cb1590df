//! The pipeline stages, in order. Each is a thin adapter over the kernel; the channels that
//! connect them are created in [`crate::pipeline`].
