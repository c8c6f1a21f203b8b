//! Reading a scene file (its size bounded before it is read); the scene model itself is the world's
//! ([`world::scene`]).

use world::scene::{MAX_SCENE_BYTES, Scene, SceneError, parse_scene};

/// Reads and validates a scene file.
pub fn load_scene(path: &std::path::Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let whole = |message: String| SceneError {
        file: file.clone(),
        line: 0,
        message,
    };
    let meta = std::fs::metadata(path).map_err(|e| whole(format!("cannot read: {e}")))?;
    if meta.len() > MAX_SCENE_BYTES {
        return Err(whole(format!(
            "{} bytes; a scene file may have at most {MAX_SCENE_BYTES}",
            meta.len()
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| whole(format!("cannot read: {e}")))?;
    parse_scene(&text, &file)
}
