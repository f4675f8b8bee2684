//! How `inspect` prints the header's coded fields: by name, and hashes in hex.

use serde::Serializer;

pub fn mode<S: Serializer>(m: &super::Mode, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(m.name())
}
pub fn transfer<S: Serializer>(t: &super::TransferKind, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(t.name())
}
pub fn backend<S: Serializer>(b: &crate::trace::Backend, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(b.name())
}
pub fn aux<S: Serializer>(a: &super::Aux, s: S) -> Result<S::Ok, S::Error> {
    let names = [(a.ao, "ao"), (a.bent_normal, "bent-normal")];
    s.collect_seq(names.iter().filter(|(on, _)| *on).map(|(_, name)| name))
}
pub fn sampling<S: Serializer>(
    m: &crate::math::sampling::Sampling,
    s: S,
) -> Result<S::Ok, S::Error> {
    s.serialize_str(m.name())
}
pub fn hex64<S: Serializer>(x: &u64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{x:016x}"))
}
pub fn up<S: Serializer>(u: &crate::scene::Up, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(u.name())
}
pub fn hex32<S: Serializer>(x: &u32, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{x:08x}"))
}
