//! The trailing section of a vertex file that covers only some of the scene's objects
//! (`bake --receivers`, aux flag bit 4): the scene's object count, then the receiving objects'
//! indices. The file's vertex count and arrays cover the receivers' vertices only, in scene
//! order; files of every object have no section, so their bytes are what they were
//! (docs/reference/coefficient-format.md, "Receiver subsets").

use serde::Serialize;

use crate::scene::Scene;

/// Which of the scene's objects a file holds transfer for.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ReceiverObjects {
    /// The scene's object count (a reader with the scene checks it).
    pub object_count: u32,
    /// The receiving objects' indices, ascending, each below `object_count`; at least one.
    pub objects: Vec<u32>,
}

impl ReceiverObjects {
    /// Bytes of the section: the two counts, then the indices.
    pub(crate) fn section_bytes(&self) -> u64 {
        8 + 4 * self.objects.len() as u64
    }

    /// The section's bytes.
    pub(crate) fn encode(&self) -> Vec<u8> {
        let mut bytes = Vec::with_capacity(self.section_bytes() as usize);
        bytes.extend(self.object_count.to_le_bytes());
        bytes.extend((self.objects.len() as u32).to_le_bytes());
        bytes.extend(self.objects.iter().flat_map(|o| o.to_le_bytes()));
        bytes
    }

    /// Reads and checks a section (all the payload after the arrays): the counts match its
    /// length, the indices ascend strictly and lie below the object count.
    pub(crate) fn decode(section: &[u8]) -> std::result::Result<ReceiverObjects, String> {
        if section.len() < 8 || section.len() % 4 != 0 {
            return Err(format!(
                "the receiver section has {} bytes (8 + 4 per receiving object)",
                section.len()
            ));
        }
        let word = |k: usize| u32::from_le_bytes(section[4 * k..4 * k + 4].try_into().expect("4"));
        let (object_count, stored) = (word(0), word(1) as usize);
        let count = section.len() / 4 - 2;
        if stored != count {
            return Err(format!(
                "the receiver section holds {count} objects, its count says {stored}"
            ));
        }
        let objects: Vec<u32> = (0..count).map(|k| word(k + 2)).collect();
        if objects.is_empty() {
            return Err("the receiver section names no object".into());
        }
        if let Some(bad) = objects.iter().find(|&&o| o >= object_count) {
            return Err(format!(
                "receiving object {bad}, but the scene has {object_count} objects"
            ));
        }
        if objects.windows(2).any(|w| w[0] >= w[1]) {
            return Err("the receiving objects are not in ascending order".into());
        }
        Ok(ReceiverObjects {
            object_count,
            objects,
        })
    }

    /// The scene vertices the file's rows are, in order.
    pub fn vertices(&self, scene: &Scene) -> Vec<u32> {
        self.objects
            .iter()
            .flat_map(|&o| scene.objects[o as usize].vertices.clone())
            .collect()
    }

    /// How many vertices the receivers have in `scene` (whose object count was checked).
    pub fn vertex_count(&self, scene: &Scene) -> u64 {
        let count = |&o: &u32| scene.objects[o as usize].vertices.len() as u64;
        self.objects.iter().map(count).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_round_trip_and_bad_ones_are_refused() {
        let r = ReceiverObjects {
            object_count: 5,
            objects: vec![1, 3],
        };
        assert_eq!(ReceiverObjects::decode(&r.encode()), Ok(r.clone()));
        let mut bytes = r.encode();
        bytes[8..12].copy_from_slice(&7u32.to_le_bytes());
        assert!(
            ReceiverObjects::decode(&bytes)
                .unwrap_err()
                .contains("object 7")
        );
        let mut bytes = r.encode();
        bytes[8..12].copy_from_slice(&3u32.to_le_bytes());
        assert!(
            ReceiverObjects::decode(&bytes)
                .unwrap_err()
                .contains("ascending")
        );
        assert!(ReceiverObjects::decode(&r.encode()[..12]).is_err());
        assert!(ReceiverObjects::decode(&[0; 8]).is_err());
    }
}
