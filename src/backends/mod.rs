//! Code generators and the machines they target.
//!
//! - `combiners`: NV_register_combiners (seeds/003 Section 4.2, Appendix B).

pub mod combiners;
