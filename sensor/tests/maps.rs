//! Map files: f32 and u8 TIFF round trips, CRC-32, and refusal of
//! truncated, corrupt, hostile or mistyped files.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use formats::{DefectCounts, SensorJson, SensorMapFiles, StackRecord};
use sensor::maps::{
    MapKind, checksum, decode_f32, decode_maps, decode_u8, encode_f32, encode_maps, encode_u8,
};
use sensor::{DefectMap, SensorError, SensorMaps};

fn gain_like(width: u32, height: u32) -> Vec<f32> {
    (0..width * height)
        .map(|i| 1.0 + 0.01 * ((i as f32) * 0.618).sin())
        .collect()
}

#[test]
fn f32_maps_round_trip_bit_exactly() {
    let (w, h) = (37, 23);
    let mut values = gain_like(w, h);
    // Awkward but finite values: sign of zero, subnormal, extremes.
    values[0] = -0.0;
    values[1] = f32::MIN_POSITIVE / 8.0;
    values[2] = f32::MAX;
    values[3] = f32::MIN;
    values[4] = 1600.125;
    let bytes = encode_f32(&values, w, h).unwrap();
    let (back, bw, bh) = decode_f32(&bytes).unwrap();
    assert_eq!((bw, bh), (w, h));
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&back), bits(&values));
    // The same map encodes to the same bytes, hence the same checksum.
    assert_eq!(
        checksum(&encode_f32(&values, w, h).unwrap()),
        checksum(&bytes)
    );
    assert_eq!(checksum(&bytes).len(), 8);
}

#[test]
fn defect_codes_round_trip() {
    let (w, h) = (40, 30);
    let mut codes = vec![0u8; (w * h) as usize];
    codes[5] = 1;
    codes[w as usize * 7 + 3] = 2;
    codes[w as usize * 7 + 4] = 2;
    codes[1199] = 4;
    let bytes = encode_u8(&codes, w, h).unwrap();
    let (back, bw, bh) = decode_u8(&bytes).unwrap();
    assert_eq!((back.clone(), bw, bh), (codes.clone(), w, h));
    let map = DefectMap::from_codes(bw, bh, &back).unwrap();
    assert_eq!(map.codes(), codes);
    assert_eq!((map.defects.len(), map.clusters.len()), (4, 1));
}

#[test]
fn a_truncated_or_corrupt_file_is_an_error() {
    let (w, h) = (64, 48);
    let bytes = encode_f32(&gain_like(w, h), w, h).unwrap();
    // Every truncation: an error, never a panic, never a short map.
    for len in (0..bytes.len()).step_by(97).chain([bytes.len() - 1]) {
        assert!(
            decode_f32(&bytes[..len]).is_err(),
            "truncated to {len} bytes"
        );
    }
    let e = decode_f32(&bytes[..bytes.len() / 2]).unwrap_err();
    eprintln!("half a file: {e}");
    // Not a TIFF at all.
    let e = decode_f32(b"this is not a tiff").unwrap_err();
    assert!(
        e.to_string().starts_with("map file: not a readable TIFF"),
        "{e}"
    );
    // Corruption anywhere: an error or a map of the right size, never a
    // panic (a flipped sample bit is a valid map; the checksum catches it).
    let reference = checksum(&bytes);
    for i in (0..bytes.len()).step_by(7) {
        let mut bad = bytes.clone();
        bad[i] ^= 0xA5;
        assert_ne!(checksum(&bad), reference);
        if let Ok((v, bw, bh)) = decode_f32(&bad) {
            assert_eq!(v.len(), bw as usize * bh as usize);
        }
    }
}

#[test]
fn a_map_of_the_wrong_sample_format_is_refused() {
    let (w, h) = (8, 4);
    let f = encode_f32(&gain_like(w, h), w, h).unwrap();
    let u = encode_u8(&vec![0u8; (w * h) as usize], w, h).unwrap();
    let e = decode_u8(&f).unwrap_err();
    assert!(
        e.to_string()
            .contains("where a 8-bit unsigned one-channel map is expected"),
        "{e}"
    );
    let e = decode_f32(&u).unwrap_err();
    assert!(
        e.to_string()
            .contains("where a 32-bit float one-channel map is expected"),
        "{e}"
    );
    // A non-finite value in a float map.
    let mut nan = gain_like(w, h);
    nan[9] = f32::NAN;
    let e = decode_f32(&encode_f32(&nan, w, h).unwrap()).unwrap_err();
    assert!(matches!(e, SensorError::MapValue { x: 1, y: 1, .. }), "{e}");
    // The encoder refuses a buffer that does not fit the size.
    assert!(encode_f32(&[1.0; 5], 2, 2).is_err());
    assert!(encode_u8(&[], 0, 0).is_err());
}

/// A minimal little-endian TIFF header with one IFD of 16-bit SHORT/LONG
/// entries, for hostile claims.
fn tiff_with(entries: &[(u16, u16, u32)]) -> Vec<u8> {
    let mut b = b"II*\0".to_vec();
    b.extend(8u32.to_le_bytes());
    b.extend((entries.len() as u16).to_le_bytes());
    for &(tag, kind, value) in entries {
        b.extend(tag.to_le_bytes());
        b.extend(kind.to_le_bytes());
        b.extend(1u32.to_le_bytes());
        b.extend(value.to_le_bytes());
    }
    b.extend(0u32.to_le_bytes());
    b.extend([0u8; 64]);
    b
}

#[test]
fn a_hostile_size_is_refused_before_anything_is_allocated() {
    const SHORT: u16 = 3;
    const LONG: u16 = 4;
    let header = |width: u32, height: u32, compression: u32| {
        tiff_with(&[
            (256, LONG, width),
            (257, LONG, height),
            (258, SHORT, 32),
            (259, SHORT, compression),
            (262, SHORT, 1),
            (273, LONG, 200),
            (277, SHORT, 1),
            (278, LONG, height),
            (279, LONG, width.saturating_mul(height).saturating_mul(4)),
            (339, SHORT, 3),
        ])
    };
    // 4 billion pixels a side.
    let e = decode_f32(&header(u32::MAX, u32::MAX, 1)).unwrap_err();
    assert!(e.to_string().contains("more than 65536 px a side"), "{e}");
    // A plausible size in a file far too short to hold it (uncompressed).
    let e = decode_f32(&header(4096, 3072, 1)).unwrap_err();
    assert!(e.to_string().contains("more than a file of"), "{e}");
    // … or deflate-compressed beyond deflate's 1032 : 1.
    let e = decode_f32(&header(4096, 3072, 8)).unwrap_err();
    assert!(e.to_string().contains("more than a file of"), "{e}");
    // A compression the maps never use (LZW).
    let e = decode_f32(&header(4, 4, 5)).unwrap_err();
    assert!(e.to_string().contains("TIFF compression 5"), "{e}");
}

/// A camera's maps: a per-pixel dark and gain, three defective pixels.
fn camera_maps(width: u32, height: u32) -> SensorMaps {
    let mut codes = vec![0u8; (width * height) as usize];
    codes[3] = 1;
    codes[17] = 2;
    codes[40] = 3;
    SensorMaps {
        width,
        height,
        black_level_dn: 96.0,
        dark: Some(gain_like(width, height).iter().map(|g| 90.0 + g).collect()),
        gain: Some(gain_like(width, height)),
        defects: DefectMap::from_codes(width, height, &codes).unwrap(),
        saturation: 4095,
    }
}

/// `rig.json`'s record of a camera whose map files are `maps`.
fn record(maps: SensorMapFiles) -> SensorJson {
    SensorJson {
        adc_bits: 12,
        container_bits: 16,
        gain_dn_per_e: None,
        read_noise_e: None,
        prnu: 0.01,
        dsnu_dn: 0.5,
        column_dsnu_dn: 0.1,
        black_level_dn: 96.0,
        saturation_dn: 4095,
        defects: DefectCounts::default(),
        stack: StackRecord {
            flats: 4,
            darks: 4,
            flat_noise_dn: None,
            dark_noise_dn: None,
        },
        maps,
        extra: Default::default(),
    }
}

#[test]
fn a_cameras_maps_come_back_from_the_files_their_record_names() {
    let (w, h) = (12, 9);
    let maps = camera_maps(w, h);
    let (files, names) = encode_maps(&maps, |k| format!("rig.cam2.{k}.tif")).unwrap();
    let kinds: Vec<MapKind> = files.iter().map(|(k, _)| *k).collect();
    assert_eq!(kinds, MapKind::ALL);
    for (kind, bytes) in &files {
        let entry = kind.entry(&names).unwrap();
        assert_eq!(entry.file, format!("rig.cam2.{}.tif", kind.name()));
        assert_eq!(entry.crc32, checksum(bytes));
    }
    assert_eq!(decode_maps(&record(names), (w, h), &files).unwrap(), maps);

    // Maps that are not applied have no file; without a defect map no pixel is defective.
    let plain = SensorMaps {
        dark: None,
        gain: None,
        defects: DefectMap::empty(w, h),
        ..maps
    };
    let (files, mut names) = encode_maps(&plain, |k| k.name().into()).unwrap();
    assert_eq!(files.len(), 1);
    assert!(names.dark.is_none() && names.gain.is_none());
    names.defects = None;
    assert_eq!(decode_maps(&record(names), (w, h), &[]).unwrap(), plain);
}

#[test]
fn a_map_file_that_is_not_the_recorded_one_is_refused_naming_its_kind() {
    let (w, h) = (12, 9);
    let (mut files, names) = encode_maps(&camera_maps(w, h), |k| k.name().into()).unwrap();
    let camera = record(names);
    let fault = |files: &[(MapKind, Vec<u8>)], size| match decode_maps(&camera, size, files) {
        Err(SensorError::Map { kind, fault }) => (kind, *fault),
        other => panic!("{other:?}"),
    };
    // Of another camera's size.
    let (kind, e) = fault(&files, (w, h + 1));
    assert_eq!(kind, MapKind::Dark);
    assert_eq!(
        e.to_string(),
        "the map is 12×9 px, but the camera is 12×10 px"
    );
    // Changed after it was recorded: its checksum, before it is decoded.
    let last = files[1].1.len() - 1;
    files[1].1[last] ^= 0xff;
    let (kind, e) = fault(&files, (w, h));
    assert_eq!(kind, MapKind::Gain);
    assert!(matches!(e, SensorError::MapChecksum { .. }), "{e}");
    assert!(
        e.to_string().contains("(the file was changed or replaced)"),
        "{e}"
    );
    // Named in the record, but its bytes not given.
    let (kind, e) = fault(&files[..1], (w, h));
    assert_eq!(kind, MapKind::Gain);
    assert!(e.to_string().contains("not given"), "{e}");
}
