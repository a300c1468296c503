//! (to be written: see the issue for the tracer method.)
