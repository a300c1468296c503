//! (to be written: see the issue for the rotary method.)
