//! Saving a screenshot (an egui `ColorImage`) as PNG.

use std::path::{Path, PathBuf};

/// Why a screenshot could not be saved or read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ScreenshotError {
    /// The image is larger than a PNG can hold.
    #[error("screenshot of {width_px}×{height_px} px is too large for a PNG")]
    TooLarge {
        /// Width, px.
        width_px: usize,
        /// Height, px.
        height_px: usize,
    },
    /// The pixel buffer does not match the image's size.
    #[error("screenshot buffer has the wrong size")]
    BufferSize,
    /// The PNG cannot be written, read or decoded.
    #[error("{}: {source}", path.display())]
    Image {
        /// The file.
        path: PathBuf,
        /// The image library's error (I/O or format).
        #[source]
        source: image::ImageError,
    },
}

/// Writes an egui colour image as an RGBA PNG.
///
/// # Errors
/// [`ScreenshotError`] when the image does not fit a PNG or the file cannot be written.
pub fn save_png(image: &egui::ColorImage, path: &Path) -> Result<(), ScreenshotError> {
    let [w, h] = image.size;
    let mut bytes = Vec::with_capacity(w * h * 4);
    for p in &image.pixels {
        bytes.extend_from_slice(&p.to_srgba_unmultiplied());
    }
    let too_large = || ScreenshotError::TooLarge {
        width_px: w,
        height_px: h,
    };
    let w32 = u32::try_from(w).map_err(|_| too_large())?;
    let h32 = u32::try_from(h).map_err(|_| too_large())?;
    let img = image::RgbaImage::from_raw(w32, h32, bytes).ok_or(ScreenshotError::BufferSize)?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|source| ScreenshotError::Image {
            path: path.to_path_buf(),
            source,
        })
}

/// Reads a PNG as RGBA: (width, height, pixels row by row, 4 bytes each).
///
/// # Errors
/// [`ScreenshotError::Image`] when the file cannot be read or decoded.
pub fn load_png(path: &Path) -> Result<(u32, u32, Vec<u8>), ScreenshotError> {
    let img = image::open(path).map_err(|source| ScreenshotError::Image {
        path: path.to_path_buf(),
        source,
    })?;
    let rgba = img.to_rgba8();
    Ok((rgba.width(), rgba.height(), rgba.into_raw()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_png_that_cannot_be_written_or_read_names_the_file() {
        let root = std::env::temp_dir().join(format!("rov_gui_png_{}", std::process::id()));
        std::fs::create_dir_all(&root).unwrap();
        let image = egui::ColorImage::new([4, 3], vec![egui::Color32::RED; 12]);
        // Round trip.
        let ok = root.join("ok.png");
        save_png(&image, &ok).unwrap();
        let (w, h, px) = load_png(&ok).unwrap();
        assert_eq!((w, h, px.len()), (4, 3, 48));
        // Into a folder that does not exist: named, with the OS error as the source.
        let missing = root.join("no/such/dir/shot.png");
        let e = save_png(&image, &missing).unwrap_err();
        assert!(matches!(&e, ScreenshotError::Image { path, .. } if path == &missing));
        assert!(
            e.to_string().starts_with(&missing.display().to_string()),
            "{e}"
        );
        assert!(std::error::Error::source(&e).is_some());
        // Not a PNG.
        let text = root.join("text.png");
        std::fs::write(&text, b"not a png").unwrap();
        let e = load_png(&text).unwrap_err();
        assert!(
            matches!(&e, ScreenshotError::Image { path, .. } if path == &text),
            "{e:?}"
        );
        std::fs::remove_dir_all(&root).ok();
    }
}
