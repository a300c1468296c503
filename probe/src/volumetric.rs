//! (to be written: see the issue for the volumetric method.)
