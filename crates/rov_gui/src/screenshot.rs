//! Saving a screenshot (an egui `ColorImage`) as PNG.

use std::path::Path;

/// Writes an egui colour image as an RGBA PNG.
///
/// # Errors
/// A message when the file cannot be written.
pub fn save_png(image: &egui::ColorImage, path: &Path) -> Result<(), String> {
    let [w, h] = image.size;
    let mut bytes = Vec::with_capacity(w * h * 4);
    for p in &image.pixels {
        bytes.extend_from_slice(&p.to_srgba_unmultiplied());
    }
    let w32 = u32::try_from(w).map_err(|e| e.to_string())?;
    let h32 = u32::try_from(h).map_err(|e| e.to_string())?;
    let img = image::RgbaImage::from_raw(w32, h32, bytes)
        .ok_or_else(|| "screenshot buffer has the wrong size".to_string())?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads a PNG as RGBA: (width, height, pixels row by row, 4 bytes each).
///
/// # Errors
/// A message when the file cannot be read or decoded.
pub fn load_png(path: &Path) -> Result<(u32, u32, Vec<u8>), String> {
    let img = image::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let rgba = img.to_rgba8();
    Ok((rgba.width(), rgba.height(), rgba.into_raw()))
}
