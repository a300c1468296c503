//! The images a command is given: files, or folders of them.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// Whether the folders given are searched into their subfolders.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Subfolders {
    /// Every folder below too (a campaign's folder of camera and run folders).
    Searched,
    /// The folder's own files only (a stack of calibration frames).
    NotSearched,
}

/// Whether `path` names a TIFF or PNG file by its extension.
fn is_image(path: &Path) -> bool {
    path.is_file()
        && path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "tif" | "tiff" | "png"))
}

/// The image files under `folder`, in the order of their paths.
fn images_in(folder: &Path, subfolders: Subfolders, found: &mut Vec<PathBuf>) -> Result<()> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(folder)
        .with_context(|| format!("{}", folder.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() && subfolders == Subfolders::Searched {
            images_in(&path, subfolders, found)?;
        } else if is_image(&path) {
            found.push(path);
        }
    }
    Ok(())
}

/// Image files of a folder (TIFF and PNG, sorted by path; in its subfolders
/// too where `subfolders` says so), or the path itself; a path that names
/// nothing, or a folder without images, is an error, before anything is
/// written.
pub fn expand_images(inputs: &[PathBuf], subfolders: Subfolders) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        if input.symlink_metadata().is_err() {
            bail!("{}: no such file or folder", input.display());
        }
        if input.is_dir() {
            let mut found = Vec::new();
            images_in(input, subfolders, &mut found)?;
            if found.is_empty() {
                let below = match subfolders {
                    Subfolders::Searched => " or its subfolders",
                    Subfolders::NotSearched => "",
                };
                bail!(
                    "{}: no TIFF or PNG images in this folder{below}",
                    input.display()
                );
            }
            files.extend(found);
        } else {
            files.push(input.clone());
        }
    }
    Ok(files)
}
