//! (to be written: the rotary method's input and output files.)
