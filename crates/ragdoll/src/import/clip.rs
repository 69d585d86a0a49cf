//! Choosing one animation of a file with several (a game character's 14 clips: "Idle",
//! "Walk", "Dance"…): whatever plays a clip plays the first, so the chosen one is kept alone.

use std::fmt::Write;
use std::path::Path;

use crate::error::{Error, Result};
use crate::skeleton::Character;

/// Most clips a "no such clip" error lists; the rest are counted.
const MAX_LISTED: usize = 40;

/// Which clip to keep: by its index in [`Character::clips`] (as `inspect` lists them) or
/// by its name.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum ClipChoice {
    /// Position in the character's clip list, from 0.
    Index(usize),
    /// The clip's name: exact, or else the one clip whose name matches ignoring case.
    Name(String),
}

impl ClipChoice {
    /// Digits are an index, anything else a name.
    pub fn parse(text: &str) -> ClipChoice {
        match text.parse::<usize>() {
            Ok(i) if text.bytes().all(|b| b.is_ascii_digit()) => ClipChoice::Index(i),
            _ => ClipChoice::Name(text.to_string()),
        }
    }
}

impl std::str::FromStr for ClipChoice {
    type Err = std::convert::Infallible;

    fn from_str(text: &str) -> std::result::Result<Self, Self::Err> {
        Ok(ClipChoice::parse(text))
    }
}

/// The index of the clip `choice` names, or `None`.
fn find(character: &Character, choice: &ClipChoice) -> Option<usize> {
    let clips = &character.clips;
    match choice {
        ClipChoice::Index(i) => (*i < clips.len()).then_some(*i),
        ClipChoice::Name(n) => clips.iter().position(|c| c.name == *n).or_else(|| {
            let mut like = (0..clips.len()).filter(|&k| clips[k].name.eq_ignore_ascii_case(n));
            match (like.next(), like.next()) {
                (Some(k), None) => Some(k),
                _ => None,
            }
        }),
    }
}

/// Keeps only the clip `choice` names, returning its index in the list as it was; an error
/// naming the file and listing its clips when there is no such clip.
pub fn choose_clip(character: &mut Character, choice: &ClipChoice, path: &Path) -> Result<usize> {
    let Some(k) = find(character, choice) else {
        let asked = match choice {
            ClipChoice::Index(i) => format!("clip {i}"),
            ClipChoice::Name(n) => format!("clip {n:?}"),
        };
        return Err(Error::NoSuchClip {
            path: path.to_path_buf(),
            asked,
            message: no_such_clip(character),
        });
    };
    let clip = character.clips.swap_remove(k);
    character.clips = vec![clip];
    Ok(k)
}

fn no_such_clip(character: &Character) -> String {
    let clips = &character.clips;
    if clips.is_empty() {
        return "no such clip: the file has no animation".into();
    }
    let mut out = format!("no such clip; the file's {} clips are", clips.len());
    for (k, c) in clips.iter().enumerate().take(MAX_LISTED) {
        let sep = if k == 0 { " " } else { ", " };
        let name = if c.name.is_empty() {
            "(unnamed)".to_string()
        } else {
            format!("{:?}", c.name)
        };
        let _ = write!(out, "{sep}{k} {name}");
    }
    if clips.len() > MAX_LISTED {
        let _ = write!(out, " and {} more", clips.len() - MAX_LISTED);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::{Clip, humanoid};

    fn with_clips(names: &[&str]) -> Character {
        let mut c = humanoid();
        let rest: Vec<_> = c.skeleton.joints().iter().map(|j| j.rest).collect();
        c.clips = names
            .iter()
            .enumerate()
            .map(|(k, n)| Clip {
                name: n.to_string(),
                frame_time: 0.1,
                frames: vec![rest.clone(); k + 1],
            })
            .collect();
        c
    }

    #[test]
    fn clips_are_chosen_by_index_or_name() {
        assert_eq!(ClipChoice::parse("3"), ClipChoice::Index(3));
        assert_eq!(ClipChoice::parse("+3"), ClipChoice::Name("+3".into()));
        assert_eq!(ClipChoice::parse("Dance"), ClipChoice::Name("Dance".into()));
        let p = Path::new("robot.glb");
        let mut c = with_clips(&["Idle", "Walk", "Dance"]);
        assert_eq!(
            choose_clip(&mut c, &ClipChoice::parse("Dance"), p).unwrap(),
            2
        );
        assert_eq!((c.clips.len(), c.clips[0].frames.len()), (1, 3));
        let mut c = with_clips(&["Idle", "Walk", "Dance"]);
        assert_eq!(
            choose_clip(&mut c, &ClipChoice::parse("walk"), p).unwrap(),
            1
        );
        assert_eq!(c.clips[0].name, "Walk");
        let mut c = with_clips(&["Idle", "Walk"]);
        assert_eq!(choose_clip(&mut c, &ClipChoice::Index(0), p).unwrap(), 0);
        assert_eq!(c.clips[0].name, "Idle");
    }

    #[test]
    fn a_missing_clip_lists_the_clips() {
        let p = Path::new("robot.glb");
        let mut c = with_clips(&["Idle", ""]);
        let e = choose_clip(&mut c, &ClipChoice::parse("Dance"), p).unwrap_err();
        assert_eq!(
            e.to_string(),
            "robot.glb: clip \"Dance\": no such clip; the file's 2 clips are 0 \"Idle\", 1 (unnamed)"
        );
        let e = choose_clip(&mut c, &ClipChoice::Index(2), p).unwrap_err();
        assert!(
            e.to_string().starts_with("robot.glb: clip 2: no such clip"),
            "{e}"
        );
        assert_eq!(
            c.clips.len(),
            2,
            "a failed choice leaves the clips as they were"
        );
        // Two names alike but for case: neither is guessed.
        let mut c = with_clips(&["run", "Run"]);
        assert!(choose_clip(&mut c, &ClipChoice::parse("RUN"), p).is_err());
        let mut c = with_clips(&[]);
        let e = choose_clip(&mut c, &ClipChoice::Index(0), p).unwrap_err();
        assert!(e.to_string().ends_with("the file has no animation"), "{e}");
    }
}
