//! The acceleration-structure suite.

mod accel_api;
