//! (to be written: generator of rotary check data with truth.)
