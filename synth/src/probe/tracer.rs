//! (to be written: generator of tracer check data with truth.)
