//! (to be written: see the issue for the indexing method.)
