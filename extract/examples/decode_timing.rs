//! Where the time of reading one TIFF goes: file read vs decode.
#![allow(missing_docs, clippy::unwrap_used)]
use std::io::Read;
use std::time::Instant;
fn main() {
    let path = std::env::args().nth(1).unwrap();
    let mut bytes = Vec::new();
    let mut reader = extract::FrameReader::new();
    for _ in 0..3 {
        let t = Instant::now();
        bytes.clear();
        std::fs::File::open(&path)
            .unwrap()
            .read_to_end(&mut bytes)
            .unwrap();
        let read = t.elapsed();
        let t = Instant::now();
        reader
            .read_bytes(&bytes, std::path::Path::new(&path))
            .unwrap();
        let dec = t.elapsed();
        let t = Instant::now();
        let m = extract::FrameMetadata::from_tiff_bytes(&bytes);
        let meta = t.elapsed();
        println!(
            "read {read:?} decode(+copy) {dec:?} exif {meta:?} {:?}",
            m.model
        );
    }
}
