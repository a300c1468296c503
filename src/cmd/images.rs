//! The images a command is given: files, or folders of them.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};

/// Image files of a folder (TIFF and PNG, sorted by name), or the path
/// itself; a path that names nothing is an error, before anything is written.
pub fn expand_images(inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        if input.symlink_metadata().is_err() {
            bail!("{}: no such file or folder", input.display());
        }
        if input.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(input)
                .with_context(|| format!("{}", input.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.is_file()
                        && p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                            matches!(e.to_ascii_lowercase().as_str(), "tif" | "tiff" | "png")
                        })
                })
                .collect();
            if found.is_empty() {
                bail!("{}: no TIFF or PNG images in this folder", input.display());
            }
            found.sort();
            files.extend(found);
        } else {
            files.push(input.clone());
        }
    }
    Ok(files)
}
