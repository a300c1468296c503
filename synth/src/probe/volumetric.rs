//! (to be written: generator of volumetric check data with truth.)
