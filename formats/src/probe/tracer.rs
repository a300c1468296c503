//! (to be written: the tracer method's input and output files.)
