//! (to be written: generator of indexing check data with truth.)
