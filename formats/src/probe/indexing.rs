//! (to be written: the indexing method's input and output files.)
