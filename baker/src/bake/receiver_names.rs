//! Which objects a bake bakes transfer for (`bake --receivers NAME[,NAME…]`): the objects
//! whose name, or (glTF) the name of whose node or any ancestor node, matches one of the
//! globs (`*`, `?`, `[…]`, as the `glob` crate matches them). Without globs, every object but
//! those a glTF node's `extras` mark `"prt": {"receive": false}` (the nearest marked node at
//! or above the object decides). The others stay in the scene: they occlude and, in
//! interreflected mode, reflect.

use crate::scene::{Hierarchy, Scene};
use crate::support::error::{Error, Result};

/// The receiving objects' indices (ascending), or `None` where every object receives (the
/// bake is an ordinary whole-scene bake). Refuses a glob that is malformed or matches no
/// object, and a choice that leaves no receiver.
pub fn receiver_objects(scene: &Scene, globs: &[String]) -> Result<Option<Vec<u32>>> {
    let chosen: Vec<bool> = match globs.is_empty() {
        true => (0..scene.objects.len())
            .map(|o| marked_receiver(scene, o))
            .collect(),
        false => {
            let patterns = globs
                .iter()
                .map(|g| {
                    glob::Pattern::new(g).map_err(|err| {
                        Error::InvalidOption(format!("--receivers: '{g}' is not a glob: {err}"))
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            let mut chosen = vec![false; scene.objects.len()];
            for (pattern, glob) in patterns.iter().zip(globs) {
                let mut matched = false;
                for (o, slot) in chosen.iter_mut().enumerate() {
                    if names(scene, o).iter().any(|name| pattern.matches(name)) {
                        *slot = true;
                        matched = true;
                    }
                }
                if !matched {
                    return Err(Error::InvalidOption(format!(
                        "--receivers: '{glob}' matches no object or node of {} (objects: {})",
                        scene.path.display(),
                        object_list(scene)
                    )));
                }
            }
            chosen
        }
    };
    if chosen.iter().all(|&c| c) {
        return Ok(None);
    }
    if !chosen.iter().any(|&c| c) {
        return Err(Error::InvalidOption(format!(
            "no object of {} receives: every node is marked \"prt\": {{\"receive\": false}}",
            scene.path.display()
        )));
    }
    Ok(Some(
        (0..chosen.len() as u32)
            .filter(|&o| chosen[o as usize])
            .collect(),
    ))
}

/// The names object `o` answers to: its own, then (glTF) its node's and its ancestors'.
fn names(scene: &Scene, o: usize) -> Vec<&str> {
    let mut names = vec![scene.objects[o].name.as_str()];
    // A back sheet is chosen with its front (docs/guides/production-assets.md, "Two-sided surfaces").
    if let Some(front) = scene.front_of(o) {
        names.push(scene.objects[front].name.as_str());
    }
    if let Some(h) = &scene.hierarchy {
        let mut node = h.object_node.get(o).copied();
        while let Some(n) = node {
            let n = &h.nodes[n as usize];
            names.push(&n.name);
            node = n.parent;
        }
    }
    names
}

/// Whether object `o` receives by its glTF nodes' marks (default: yes).
fn marked_receiver(scene: &Scene, o: usize) -> bool {
    let Some(h) = &scene.hierarchy else {
        return true;
    };
    let mut node = h.object_node.get(o).copied();
    while let Some(n) = node {
        let n = &h.nodes[n as usize];
        if let Some(receive) = n.receive {
            return receive;
        }
        node = n.parent;
    }
    true
}

/// The first few object names, for an error message.
fn object_list(scene: &Scene) -> String {
    const SHOWN: usize = 8;
    let mut list: Vec<String> = scene
        .objects
        .iter()
        .take(SHOWN)
        .map(|o| format!("'{}'", o.name))
        .collect();
    if scene.objects.len() > SHOWN {
        list.push(format!("and {} more", scene.objects.len() - SHOWN));
    }
    list.join(", ")
}

/// Whether an object named `name`, from node `node` of a glTF `hierarchy`, receives under
/// `globs`, as [`receiver_objects`] decides (a malformed glob matches nothing here; that
/// function refuses it). For a load to know which objects it may keep as instances
/// ([`crate::scene::Instancing`]) before the scene exists.
pub fn receives(globs: &[String]) -> impl Fn(&Hierarchy, u32, &str) -> bool + use<> {
    let patterns: Vec<glob::Pattern> = globs
        .iter()
        .filter_map(|g| glob::Pattern::new(g).ok())
        .collect();
    let marks = globs.is_empty();
    move |hierarchy, node, name| {
        let mut at = Some(node);
        if marks {
            while let Some(n) = at {
                let n = &hierarchy.nodes[n as usize];
                if let Some(receive) = n.receive {
                    return receive;
                }
                at = n.parent;
            }
            return true;
        }
        let mut names = vec![name];
        while let Some(n) = at {
            let n = &hierarchy.nodes[n as usize];
            names.push(&n.name);
            at = n.parent;
        }
        patterns.iter().any(|p| names.iter().any(|n| p.matches(n)))
    }
}
