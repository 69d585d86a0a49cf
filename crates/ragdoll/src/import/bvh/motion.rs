//! The motion section: `Frames:`, `Frame Time:` and one line per frame, each converted to
//! joint poses as it is read.

use std::path::Path;

use super::FRAME_TIME_RANGE_S;
use super::hierarchy::PJoint;
use super::parse::Convert;
use super::text::{Lines, check_range, parse_error, parse_number};
use crate::error::Result;
use crate::math::Transform;
use crate::skeleton::MAX_CLIP_POSES;

/// Case-insensitive ASCII prefix strip that cannot split a UTF-8 character.
fn strip_prefix_ci<'s>(s: &'s str, prefix: &str) -> Option<&'s str> {
    let head = s.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix)
        .then(|| s.get(prefix.len()..))
        .flatten()
}

/// The value after `key` on a header line such as `Frames: 12` or `Frame Time:\t0.01`.
fn header_value<'s>(line: &'s str, key: &[&str]) -> Option<&'s str> {
    let mut rest = line.trim();
    for (i, word) in key.iter().enumerate() {
        if i > 0 {
            rest = rest.trim_start();
        }
        rest = strip_prefix_ci(rest, word)?;
    }
    let rest = rest.trim_start();
    let rest = rest.strip_prefix(':').unwrap_or(rest);
    Some(rest.trim())
}

/// The motion section, converted.
pub(super) struct Motion {
    /// The `Frames:` count.
    pub(super) count: usize,
    pub(super) frame_time: f64,
    /// Every frame's local joint transforms; `None` when the hierarchy has no channels
    /// (every frame is the rest pose, made once the skeleton exists).
    pub(super) frames: Option<Vec<Vec<Transform>>>,
    /// 1-based line of each frame.
    pub(super) frame_lines: Vec<usize>,
}

/// Reads `Frames:`, `Frame Time:` and the frame lines after the `MOTION` line, converting
/// each frame as it is read. Nothing is reserved from the announced count: a frame takes
/// memory only once its line has been read.
pub(super) fn read_motion(
    path: &Path,
    lines: &mut Lines,
    motion_line: usize,
    joints: &[PJoint],
    convert: &Convert,
) -> Result<Motion> {
    let channels: usize = joints.iter().map(|j| j.channels.len()).sum();
    let mut rest = lines.filter(|(_, l)| !l.trim().is_empty());
    let announced = read_frame_count(path, &mut rest, motion_line)?;
    check_clip_size(path, announced, joints.len())?;
    let (time_line, frame_time) = read_frame_time(path, &mut rest, announced.line)?;
    let (frames, frame_lines) = read_frames(path, rest, announced, joints, convert, channels)?;
    let last_line = frame_lines.last().copied().unwrap_or(time_line);
    // Without channels every frame is the rest pose: there are no frame lines to miss.
    if channels > 0 {
        check_no_missing_frames(path, announced, frame_lines.len(), last_line)?;
    }
    Ok(Motion {
        count: announced.count,
        frame_time,
        frames: (channels > 0).then_some(frames),
        frame_lines,
    })
}

/// The `Frames:` count, kept with its 1-based line so that the errors about too many or
/// too few frame lines can point back at it.
#[derive(Clone, Copy)]
struct Announced {
    count: usize,
    line: usize,
}

/// `Frames:` must be the first line with anything on it after `MOTION`. The count is only
/// parsed here, not trusted: [`check_clip_size`] bounds it.
fn read_frame_count<'a>(
    path: &Path,
    rest: &mut impl Iterator<Item = (usize, &'a str)>,
    motion_line: usize,
) -> Result<Announced> {
    let Some((frames_line, line)) = rest.next() else {
        return Err(parse_error(
            path,
            motion_line,
            "the file ends after MOTION; expected \"Frames: <count>\"",
        ));
    };
    let count: usize = header_value(line, &["Frames"])
        .ok_or_else(|| {
            parse_error(
                path,
                frames_line,
                format!("expected \"Frames: <count>\", found \"{}\"", line.trim()),
            )
        })?
        .parse()
        .map_err(|_| {
            parse_error(
                path,
                frames_line,
                format!("the frame count is not a whole number: \"{}\"", line.trim()),
            )
        })?;
    Ok(Announced {
        count,
        line: frames_line,
    })
}

/// The clip holds frames × joints transforms; refuse sizes that would exhaust memory
/// (a crash, not an error) rather than trust the count or a pathological hierarchy.
fn check_clip_size(path: &Path, announced: Announced, joints: usize) -> Result<()> {
    let count = announced.count;
    if count.saturating_mul(joints) > MAX_CLIP_POSES {
        return Err(parse_error(
            path,
            announced.line,
            format!(
                "{count} frames of {joints} joints exceed the {MAX_CLIP_POSES} joint poses this importer holds in memory"
            ),
        ));
    }
    Ok(())
}

/// Also returns the `Frame Time:` line, which a short motion section cites when it has no
/// frame lines. A file that ends before it is reported at `Frames:`, as it has no line of
/// its own to cite.
fn read_frame_time<'a>(
    path: &Path,
    rest: &mut impl Iterator<Item = (usize, &'a str)>,
    frames_line: usize,
) -> Result<(usize, f64)> {
    let Some((time_line, line)) = rest.next() else {
        return Err(parse_error(
            path,
            frames_line,
            "the file ends before \"Frame Time: <seconds>\"",
        ));
    };
    let frame_time = header_value(line, &["Frame", "Time"]).ok_or_else(|| {
        parse_error(
            path,
            time_line,
            format!(
                "expected \"Frame Time: <seconds>\", found \"{}\"",
                line.trim()
            ),
        )
    })?;
    let frame_time = parse_number(frame_time)
        .filter(|t| *t > 0.0)
        .ok_or_else(|| {
            parse_error(
                path,
                time_line,
                format!(
                    "the frame time is not a positive number: \"{}\"",
                    line.trim()
                ),
            )
        })?;
    let [lo, hi] = FRAME_TIME_RANGE_S;
    if !(lo..=hi).contains(&frame_time) {
        return Err(parse_error(
            path,
            time_line,
            format!(
                "the frame time {frame_time} s is outside the {lo} to {hi} s this importer accepts"
            ),
        ));
    }
    Ok((time_line, frame_time))
}

/// Each frame is converted as soon as its line is read, so memory grows with the lines
/// actually present, never with the announced count; one value buffer serves every line.
fn read_frames<'a>(
    path: &Path,
    rest: impl Iterator<Item = (usize, &'a str)>,
    announced: Announced,
    joints: &[PJoint],
    convert: &Convert,
    channels: usize,
) -> Result<(Vec<Vec<Transform>>, Vec<usize>)> {
    let mut frames = Vec::new();
    let mut frame_lines = Vec::new();
    let Announced {
        count,
        line: frames_line,
    } = announced;
    let mut row = Vec::with_capacity(channels);
    for (line_no, line) in rest {
        let f = frame_lines.len();
        if f >= count {
            return Err(parse_error(
                path,
                line_no,
                format!(
                    "more frame lines than the {count} that \"Frames:\" (line {frames_line}) announces"
                ),
            ));
        }
        read_frame_values(path, line_no, line, f, channels, &mut row)?;
        frames.push(convert.frame(joints, &row));
        frame_lines.push(line_no);
    }
    Ok((frames, frame_lines))
}

/// Fills `row` with frame `f`'s values (`f` 0-based). The values are counted before any
/// is parsed, so a short or long line is reported as such, not as its first bad value.
fn read_frame_values(
    path: &Path,
    line_no: usize,
    line: &str,
    f: usize,
    channels: usize,
    row: &mut Vec<f64>,
) -> Result<()> {
    let n = line.split_whitespace().count();
    if n != channels {
        return Err(parse_error(
            path,
            line_no,
            format!(
                "frame {} has {n} values, but the hierarchy has {channels} channels",
                f + 1
            ),
        ));
    }
    row.clear();
    for (k, word) in line.split_whitespace().enumerate() {
        let what = || format!("value {} of frame {}", k + 1, f + 1);
        let v = parse_number(word)
            .ok_or_else(|| {
                parse_error(
                    path,
                    line_no,
                    format!("{} is not a finite number: \"{word}\"", what()),
                )
            })
            .and_then(|v| check_range(v, &what()).map_err(|m| parse_error(path, line_no, m)))?;
        row.push(v);
    }
    Ok(())
}

/// A short motion section is reported at the line after the last frame read (or after
/// `Frame Time:` when there is none): where the first missing frame was expected.
fn check_no_missing_frames(
    path: &Path,
    announced: Announced,
    read: usize,
    last_line: usize,
) -> Result<()> {
    let Announced {
        count,
        line: frames_line,
    } = announced;
    if read < count {
        return Err(parse_error(
            path,
            last_line + 1,
            format!(
                "the motion data ends after {read} frames, but \"Frames:\" (line {frames_line}) announces {count}"
            ),
        ));
    }
    Ok(())
}
