//! The diagnostics counts of a `tcpf` run.

/// Diagnostics of a `tcpf` run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TcpfCounts {
    /// Global starts (from a measurement set, including floor changes
    /// onto a floor where the track's point is not walkable).
    pub global_starts: u64,
    /// Radio updates that weighed the particles.
    pub radio_updates: u64,
    /// Particles killed by a move through a wall.
    pub wall_killed: u64,
    /// Steps every particle tried to make through a wall (undone).
    pub steps_blocked: u64,
    /// Particles re-seeded from the likelihood surface.
    pub reseeded: u64,
    /// Fusion runs that held the published point instead of jumping
    /// through a wall; moves of it along a walk through the doors toward
    /// the cloud after the hold ran out; jumps where the map had no way
    /// (not eval's `jumps`, which counts every jump of the published track).
    pub held: u64,
    pub walked: u64,
    pub jumps_no_way: u64,
    pub floor_changes: u64,
    /// Barometer floor changes not made: the new floor's plan has no
    /// walkable point within `floor_snap_m` of the track (a stairwell the
    /// plan lacks, passed through).
    pub floor_changes_off_map: u64,
    /// Anchor queries that gave candidates, and particles re-seeded
    /// around them.
    pub anchor_queries: u64,
    /// Re-seedings not done: the phone far from the survey
    /// (`anchors.far_db`).
    pub reseed_far: u64,
    /// Radio updates made with the phone far from the survey
    /// (`anchors.far_db`: the window's closest reference scan farther than
    /// the level in force).
    pub far_updates: u64,
    /// Radio updates made with the radio's trust below 1 and below 0.5
    /// (`integrity`).
    pub trust_reduced: u64,
    pub trust_low: u64,
}

impl TcpfCounts {
    /// Every count with its field's name (the destructuring lists every
    /// field, so a new count does not compile until it is named here).
    pub fn named(&self) -> [(&'static str, u64); 15] {
        let TcpfCounts {
            global_starts,
            radio_updates,
            wall_killed,
            steps_blocked,
            reseeded,
            held,
            walked,
            jumps_no_way,
            floor_changes,
            floor_changes_off_map,
            anchor_queries,
            reseed_far,
            far_updates,
            trust_reduced,
            trust_low,
        } = *self;
        [
            ("global_starts", global_starts),
            ("radio_updates", radio_updates),
            ("wall_killed", wall_killed),
            ("steps_blocked", steps_blocked),
            ("reseeded", reseeded),
            ("held", held),
            ("walked", walked),
            ("jumps_no_way", jumps_no_way),
            ("floor_changes", floor_changes),
            ("floor_changes_off_map", floor_changes_off_map),
            ("anchor_queries", anchor_queries),
            ("reseed_far", reseed_far),
            ("far_updates", far_updates),
            ("trust_reduced", trust_reduced),
            ("trust_low", trust_low),
        ]
    }
}
