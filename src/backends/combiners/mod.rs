//! The register-combiner machine of seeds/003 Section 4.2 and Appendix B.
