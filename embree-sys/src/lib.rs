//! Bindings over the Embree that the system ships (Debian 12: Embree 3.13; Debian 13: Embree 4.3),
//! generated at build time by bindgen, and a small safe API for what a radiance-transfer baker needs:
//! static triangle scenes, occlusion queries and closest-hit queries.
//!
//! * [`Device`] wraps `RTCDevice`; Embree's error callback and `rtcGetDeviceError` become [`Error`].
//! * [`SceneBuilder`] collects triangle meshes from plain slices (copied into Embree-owned
//!   buffers, so no borrow outlives the call) and [`SceneBuilder::commit`]s them into a
//!   [`CommittedScene`], the only type that answers queries. It is `Send + Sync`.
//! * Queries come in three shapes so callers can reach Embree's fast paths: single rays
//!   ([`CommittedScene::occluded1`]), 16-wide packets ([`CommittedScene::occluded16`], fed from
//!   [`Ray16`]) and streams ([`CommittedScene::occluded_stream`], `rtcOccluded1M` on Embree 3;
//!   Embree 4 removed streams, so there it is served by 16-wide packets).
//!
//! The generated declarations are in [`sys`]; only this crate calls them.

#![warn(clippy::undocumented_unsafe_blocks)]

mod device;
mod error;
mod filter;
mod query;
mod ray;
mod scene;

/// The raw declarations bindgen generated from `rtcore.h` (`rtc*` functions, `RTC*` types).
#[allow(
    non_upper_case_globals,
    non_camel_case_types,
    non_snake_case,
    dead_code
)]
#[allow(clippy::all, clippy::undocumented_unsafe_blocks)]
pub mod sys {
    include!(concat!(env!("OUT_DIR"), "/bindings.rs"));

    /// `#define RTC_INVALID_GEOMETRY_ID ((unsigned int)-1)`: a cast macro bindgen cannot translate.
    pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
}

pub use device::Device;
pub use error::{Error, ErrorKind};
pub use filter::HitFilter;
pub use ray::{Hit, PACKET_WIDTH, Ray, Ray16, RayHit, RayHit16};
pub use scene::{BuildQuality, CommittedScene, SceneBuilder, SceneFlags};

/// The Embree major version these bindings were generated for (3 or 4).
pub const EMBREE_MAJOR: u32 = if cfg!(embree_v4) { 4 } else { 3 };
