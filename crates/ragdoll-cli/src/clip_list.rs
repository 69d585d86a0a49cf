//! `inspect`'s clip listing: every clip the file has, by the index and name `--clip` takes,
//! with the one that plays marked.

use std::fmt::Write;

use anyhow::Result;
use ragdoll::import::{self, ClipChoice};
use ragdoll::skeleton::{Character, Clip};

use crate::character::import_error;

/// The character's clips as read, before `--clip` keeps one.
pub struct Clips {
    all: Vec<Summary>,
    /// Index of the clip that plays (the first, or the one `--clip` chose).
    played: Option<usize>,
}

struct Summary {
    name: String,
    frames: usize,
    duration_s: f32,
    fps: f32,
}

impl Summary {
    fn of(c: &Clip) -> Self {
        Summary {
            name: c.name.clone(),
            frames: c.frames.len(),
            duration_s: c.duration(),
            fps: 1.0 / c.frame_time,
        }
    }
}

/// Lists the character's clips, then keeps only the one `choice` names (as loading with
/// `--clip` does), so what is built from the character is built from that clip.
pub fn list_and_choose(
    character: &mut Character,
    choice: Option<&str>,
    file: &std::path::Path,
) -> Result<Clips> {
    let all: Vec<Summary> = character.clips.iter().map(Summary::of).collect();
    let played = match choice {
        Some(c) => Some(
            import::choose_clip(character, &ClipChoice::parse(c), file).map_err(import_error)?,
        ),
        None => (!all.is_empty()).then_some(0),
    };
    Ok(Clips { all, played })
}

impl Clips {
    /// How many clips the file has.
    pub fn count(&self) -> usize {
        self.all.len()
    }

    /// The JSON array of `inspect --json`.
    pub fn json(&self) -> serde_json::Value {
        self.all
            .iter()
            .enumerate()
            .map(|(k, c)| {
                serde_json::json!({
                    "index": k,
                    "name": c.name,
                    "frames": c.frames,
                    "duration_s": c.duration_s,
                    "fps": c.fps,
                    "played": self.played == Some(k),
                })
            })
            .collect()
    }

    /// The text section: one line a clip, the one that plays marked with `*`.
    pub fn write(&self, out: &mut String) -> std::fmt::Result {
        if self.all.is_empty() {
            return writeln!(out, "\nclips: none");
        }
        writeln!(
            out,
            "\nclips (* plays; choose another with --clip NAME|INDEX):"
        )?;
        for (k, c) in self.all.iter().enumerate() {
            let mark = if self.played == Some(k) { '*' } else { ' ' };
            let name = if c.name.is_empty() {
                "(unnamed)".to_string()
            } else {
                format!("{:?}", c.name)
            };
            writeln!(
                out,
                "{mark} {k:>3}  {name:<24} {:.2} s, {} frames at {:.0} fps",
                c.duration_s, c.frames, c.fps
            )?;
        }
        Ok(())
    }
}
