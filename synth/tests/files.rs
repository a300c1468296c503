//! Image files: pixels read back by the image crate, metadata read back by
//! kamadak-exif, for 16- and 8-bit TIFF and PNG; same seed → same bytes.

#![allow(clippy::unwrap_used)]

use std::io::BufReader;
use std::path::Path;

use geom::Point3;
use synth::config::{ImageFormat, TiffCompression};
use synth::{Config, FrameMetadata, NoiseKey, Overrides, Sphere, SynthRig, write_image};

fn small_camera() -> synth::SynthCamera {
    let mut config = Config::default();
    config
        .apply(&Overrides {
            width: Some(256),
            height: Some(192),
            ..Overrides::default()
        })
        .unwrap();
    SynthRig::from_config(&config)
        .unwrap()
        .camera(2)
        .unwrap()
        .clone()
}

fn frame(cam: &synth::SynthCamera, seed: u64) -> synth::Image16 {
    let spheres = [Sphere {
        centre: Point3::new(5.0, 0.0, 30.0),
        radius: 10.0,
        radiance_e: 12_000.0,
    }];
    cam.render(
        &spheres,
        NoiseKey {
            seed,
            frame: 4,
            camera: cam.id,
        },
        4,
    )
    .unwrap()
}

fn meta() -> FrameMetadata {
    FrameMetadata {
        make: "trinocular".into(),
        model: "synth".into(),
        serial: "TRN-SYN-0002".into(),
        // 2025-06-02 08:00:00.0125
        time_s: 1_748_851_200.0 + 0.0125,
        exposure_s: 0.002,
        f_number: 8.0,
        focal_mm: 40.0,
        description: "test frame".into(),
    }
}

fn field(exif: &exif::Exif, tag: exif::Tag) -> String {
    exif.get_field(tag, exif::In::PRIMARY)
        .unwrap_or_else(|| panic!("missing {tag}"))
        .display_value()
        .to_string()
}

fn check_exif(path: &Path) {
    let file = std::fs::File::open(path).unwrap();
    let exif = exif::Reader::new()
        .read_from_container(&mut BufReader::new(file))
        .unwrap();
    assert_eq!(field(&exif, exif::Tag::Make), "\"trinocular\"");
    assert_eq!(field(&exif, exif::Tag::Model), "\"synth\"");
    assert_eq!(
        field(&exif, exif::Tag::BodySerialNumber),
        "\"TRN-SYN-0002\""
    );
    assert_eq!(field(&exif, exif::Tag::DateTime), "2025-06-02 08:00:00");
    assert_eq!(
        field(&exif, exif::Tag::DateTimeOriginal),
        "2025-06-02 08:00:00"
    );
    assert_eq!(field(&exif, exif::Tag::SubSecTimeOriginal), "\"0125\"");
    let exposure = exif
        .get_field(exif::Tag::ExposureTime, exif::In::PRIMARY)
        .unwrap();
    match &exposure.value {
        exif::Value::Rational(r) => assert_eq!((r[0].num, r[0].denom), (1, 500)),
        v => panic!("ExposureTime is {v:?}"),
    }
}

#[test]
fn tiff_and_png_round_trip_pixels_and_metadata() {
    let cam = small_camera();
    let img = frame(&cam, 1);
    assert!(
        img.iter().any(|&v| v > 20_000),
        "the sphere is not in the frame"
    );
    let dir = tempfile::tempdir().unwrap();
    for (format, compression, bits) in [
        (ImageFormat::Tiff, TiffCompression::None, 16u8),
        (ImageFormat::Tiff, TiffCompression::Deflate, 16),
        (ImageFormat::Tiff, TiffCompression::Lzw, 16),
        (ImageFormat::Tiff, TiffCompression::None, 8),
        (ImageFormat::Png, TiffCompression::None, 16),
        (ImageFormat::Png, TiffCompression::None, 8),
    ] {
        let path = dir
            .path()
            .join(format!("f{bits}_{compression:?}.{}", format.extension()));
        let data = if bits == 8 {
            image::ImageBuffer::from_raw(
                img.width(),
                img.height(),
                img.iter().map(|&v| v / 257).collect(),
            )
            .unwrap()
        } else {
            img.clone()
        };
        write_image(&path, &data, bits, &meta(), format, compression).unwrap();
        let back = image::open(&path).unwrap();
        if bits == 16 {
            assert_eq!(back.to_luma16().as_raw(), data.as_raw(), "{path:?}");
        } else {
            let want: Vec<u8> = data.iter().map(|&v| v as u8).collect();
            assert_eq!(back.to_luma8().as_raw(), &want, "{path:?}");
        }
        check_exif(&path);
    }
}

#[test]
fn same_seed_same_bytes() {
    let cam = small_camera();
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, seed: u64| {
        let path = dir.path().join(name);
        write_image(
            &path,
            &frame(&cam, seed),
            16,
            &meta(),
            ImageFormat::Tiff,
            TiffCompression::None,
        )
        .unwrap();
        std::fs::read(path).unwrap()
    };
    let a = write("a.tif", 1);
    let b = write("b.tif", 1);
    let c = write("c.tif", 2);
    assert_eq!(a, b);
    assert_ne!(a, c);
}

/// A whole frame (coverage, blur and noise all run in parallel) is the same
/// on 1 and on 3 threads.
#[test]
fn frame_bytes_do_not_depend_on_threads() {
    let cam = small_camera();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let a = one.install(|| frame(&cam, 9));
    let b = three.install(|| frame(&cam, 9));
    assert_eq!(a.as_raw(), b.as_raw());
}
