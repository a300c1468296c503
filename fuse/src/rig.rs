//! A calibrated rig read whole: `rig.json` and the per-pixel sensor maps
//! that its cameras' `sensor` records name beside it, each file checked
//! against its record (`sensor::maps::decode_maps`).

use std::collections::BTreeMap;
use std::path::Path;

use formats::Rig;
use sensor::SensorMaps;
use sensor::maps::MapKind;

use crate::{FuseError, Result};

/// The cameras of `rig.json` and the sensor maps their frames are corrected
/// with (per camera id; a camera without a `sensor` record has none).
#[derive(Debug, Clone)]
pub struct CalibratedRig {
    /// `rig.json`.
    pub rig: Rig,
    /// Per camera id, the maps of its `sensor` record.
    pub sensor: BTreeMap<u8, SensorMaps>,
}

impl CalibratedRig {
    /// Read `rig.json` at `path` and the map files its cameras' records name
    /// (relative to its folder), each of the camera's size and with the
    /// checksum its record gives; a fault names the rig, the camera and the
    /// file.
    pub fn read(path: &Path) -> Result<Self> {
        let rig = formats::read_rig(path)?;
        let mut sensor = BTreeMap::new();
        for camera in &rig.cameras {
            let Some(record) = &camera.sensor else {
                continue;
            };
            let id = camera.model.id;
            let file = |kind: MapKind| {
                kind.entry(&record.maps)
                    .map(|m| formats::folder_of(path).join(&m.file))
            };
            let mut files = Vec::new();
            for kind in MapKind::ALL {
                if let Some(file) = file(kind) {
                    let bytes = std::fs::read(&file).map_err(|source| FuseError::MapRead {
                        rig: path.to_path_buf(),
                        camera: id,
                        file,
                        source,
                    })?;
                    files.push((kind, bytes));
                }
            }
            let size = (camera.model.width, camera.model.height);
            let maps = sensor::maps::decode_maps(record, size, &files).map_err(|e| {
                let (file, fault) = match e {
                    sensor::SensorError::Map { kind, fault } => (file(kind), *fault),
                    other => (None, other),
                };
                FuseError::SensorMap {
                    rig: path.to_path_buf(),
                    camera: id,
                    file: file.unwrap_or_else(|| path.to_path_buf()),
                    fault,
                }
            })?;
            sensor.insert(id, maps);
        }
        Ok(Self { rig, sensor })
    }
}
