//! (to be written: the volumetric method's input and output files.)
