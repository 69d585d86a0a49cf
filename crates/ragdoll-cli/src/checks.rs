//! Flag combinations that could never have an effect, refused with a sentence before any
//! work rather than silently dropped. Value ranges are the library's to check; these are
//! the facts only the command line knows (which flags came together, how long the run is).

use std::path::Path;

use anyhow::{Result, bail};
use ragdoll::world::Activation;

use ragdoll::skeleton::Character;

use crate::{AnimArgs, ImportArgs, SimArgs};

/// `--activate` that would never hand over to physics in this run: `blast` without a
/// blast, `contact` where nothing but the ground can touch the character (a lone
/// character is touched only by a shot), or a time at or past the end of the run.
pub fn activation(sim: &SimArgs, has_blast: bool, has_shot: bool) -> Result<()> {
    let seconds = sim.run.seconds;
    match sim.anim.activate {
        Activation::OnBlast if !has_blast => bail!(
            "--activate blast: this run has no blast, so physics would never take over (`ragdoll blast` sets one off; a scene file can hold several)"
        ),
        Activation::OnContact if !has_shot => bail!(
            "--activate contact: nothing but the ground can touch a lone character in this run, so physics would never take over (`ragdoll shoot` fires a shot; a scene file can hold several characters)"
        ),
        Activation::AtTime(t) if t >= seconds => bail!(
            "--activate {t}: physics would take over at or after the end of the run (--seconds {seconds})"
        ),
        _ => Ok(()),
    }
}

/// An event (`what`, timed by `flag`) set after the run ends would never happen.
pub fn event_time(flag: &str, what: &str, time_s: f32, seconds: f32) -> Result<()> {
    if time_s > seconds {
        bail!("{flag} {time_s}: {what} would come after the run ends (--seconds {seconds})");
    }
    Ok(())
}

/// `--rest-pose` on a character without an animation: it starts from its rest pose anyway.
/// (`--activate` and `--powered` without one are refused by the world, naming the flag.)
pub fn rest_pose(character: &Character, anim: &AnimArgs) -> Result<()> {
    let animated = character.clips.iter().any(|c| !c.frames.is_empty());
    if anim.rest_pose && !animated {
        bail!(
            "--rest-pose: {} has no animation, so it starts from its rest pose anyway",
            character.name
        );
    }
    Ok(())
}

/// Import flags that cannot apply: none applies to the built-in humanoid, which is no
/// file; `--up` not to glTF or VRM, which are Y up by definition. (`--units` does apply to
/// glTF: files exported in centimetres are common. A `--clip` the file lacks is the
/// library's to refuse, listing the clips.)
pub fn import_flags(file: Option<&Path>, a: &ImportArgs) -> Result<()> {
    let given: Vec<&str> = [
        (a.units.is_some(), "--units"),
        (a.up.is_some(), "--up"),
        (a.height.is_some(), "--height"),
        (a.clip.is_some(), "--clip"),
    ]
    .into_iter()
    .filter_map(|(g, flag)| g.then_some(flag))
    .collect();
    let Some(file) = file else {
        if given.is_empty() {
            return Ok(());
        }
        bail!(
            "{}: the built-in humanoid is not a file; these flags apply to character files",
            given.join(", ")
        );
    };
    if a.up.is_some() && ragdoll::import::is_gltf(file) {
        bail!(
            "--up: {} is glTF, which is Y up by definition; --up applies to BVH and OBJ files",
            file.display()
        );
    }
    Ok(())
}
