//! Cost-adaptive occlusion culling: whether a frame's occlusion culling pays for itself.
//!
//! On a model that is cheap to draw, or seen where little is hidden (a game level's open
//! courtyards, a small engine), OR's pass, the depth read-back and HC's tests cost more than
//! the triangles they save RVG. CHC++ (Mattausch et al. 2008) skips the tests that do not pay;
//! Bartz 1999's eq. 2 stops them after a time budget. Here a frame that culls is judged by its
//! counts: the triangles occlusion culling kept from RVG against what it cost, in triangles'
//! worth ([`CullCost`]). While it does not pay, frames are frustum culled only, for a number of
//! frames that grows each time a probe finds it still does not pay (up to [`MAX_SKIP`]), so
//! that culling is taken up again where the view changes. The occluders are counted as OR
//! would draw them in a steady state, the frame's PVS: a probe after skipped frames draws the
//! whole frustum-culled set as occluders once, which would never pay.
//!
//! The judgement uses counts, never a frame's wall-clock time: prev and the switch's nodes,
//! fed the same frames, decide alike, and a run repeats. In the switch each node judges the
//! frames it culls (every other one), deciding for its next one from its last; prev keeps two
//! judges, one per parity of the frame, to decide as the two nodes do.

/// What a frame's occlusion culling costs, in triangles' worth of RVG's draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CullCost {
    /// Per frame: the depth read back, its pyramid and the retests' round trips.
    pub frame: f64,
    /// Per triangle OR draws into the depth buffer.
    pub occluder: f64,
    /// Per box tested.
    pub test: f64,
}

impl CullCost {
    /// The cost at an image of `pixels`: a culled frame's fixed work (the depth read back, its
    /// pyramid, the second look's round trips) grows with the pixels read back, OR draws a
    /// triangle at about RVG's cost, and a box test on the CPU pyramid costs about a quarter of
    /// one (docs/measurements/2026-12-07-constants.md, "CullCost").
    pub fn at(pixels: u64) -> CullCost {
        CullCost { frame: pixels as f64 / 128.0, occluder: 1.0, test: 0.25 }
    }
}

/// A culled frame's counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CullCounts {
    /// Triangles of the nodes occlusion culling removed (at full detail for a BVH node: an
    /// upper bound of what RVG would have drawn).
    pub culled_triangles: u64,
    /// Triangles of the PVS: what OR draws the next frame.
    pub occluder_triangles: u64,
    pub tests: u64,
}

/// Triangles of LOD nodes `ids` by the node table (OR's occluders in a steady state: the PVS).
pub fn triangles(nodes: &[osw_scene::NodeRecord], ids: &[osw_scene::NodeId]) -> u64 {
    ids.iter().map(|&id| nodes[id as usize].triangles).sum()
}

/// Most frames skipped between two probes.
pub const MAX_SKIP: u32 = 64;
/// Frames skipped after the first frame that does not pay; each probe that does not pay
/// skips this many times more: probes that grow faster waste fewer culled frames where culling
/// never pays (docs/measurements/2026-12-07-constants.md, "FIRST_SKIP").
const FIRST_SKIP: u32 = 8;
const GROWTH: u32 = 4;

/// Judges one sequence of frames (see the module).
#[derive(Clone, Debug)]
pub struct Payoff {
    cost: CullCost,
    /// Frames still to skip, and how many the next time culling does not pay.
    skip: u32,
    next_skip: u32,
}

impl Payoff {
    pub fn new(cost: CullCost) -> Payoff {
        Payoff { cost, skip: 0, next_skip: FIRST_SKIP }
    }

    /// The same judge for a new path: nothing skipped.
    pub fn restart(&mut self) {
        (self.skip, self.next_skip) = (0, FIRST_SKIP);
    }

    /// Whether this frame is occlusion culled.
    pub fn cull(&mut self) -> bool {
        if self.skip == 0 {
            return true;
        }
        self.skip -= 1;
        false
    }

    /// Judges a frame HC culled into `pvs` with counts `hc`: the occluders OR draws next are
    /// the PVS, by the node table (not what cluster tests let through, so that every process
    /// judges alike).
    pub fn judge_hc(&mut self, nodes: &[osw_scene::NodeRecord], hc: &crate::HcStats, pvs: &[osw_scene::NodeId]) {
        self.judge(CullCounts { culled_triangles: hc.culled_triangles, occluder_triangles: triangles(nodes, pvs), tests: hc.tests as u64 });
    }

    /// Judges a culled frame by its counts; a frame that does not pay skips the next ones.
    pub fn judge(&mut self, c: CullCounts) {
        let cost = self.cost.frame + self.cost.occluder * c.occluder_triangles as f64 + self.cost.test * c.tests as f64;
        if c.culled_triangles as f64 >= cost {
            self.next_skip = FIRST_SKIP;
        } else {
            self.skip = self.next_skip;
            self.next_skip = (self.next_skip * GROWTH).min(MAX_SKIP);
        }
    }
}

/// Two judges, one per parity of the frame number: prev deciding as the switch's two nodes do.
#[derive(Clone, Debug)]
pub struct Alternating([Payoff; 2]);

impl Alternating {
    pub fn new(cost: CullCost) -> Alternating {
        Alternating([Payoff::new(cost), Payoff::new(cost)])
    }

    pub fn of(&mut self, frame: u64) -> &mut Payoff {
        &mut self.0[(frame % 2) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const COST: CullCost = CullCost { frame: 1000.0, occluder: 1.0, test: 0.25 };

    #[test]
    fn culling_that_pays_goes_on() {
        let mut p = Payoff::new(COST);
        for _ in 0..100 {
            assert!(p.cull());
            p.judge(CullCounts { culled_triangles: 100_000, occluder_triangles: 20_000, tests: 4000 });
        }
    }

    #[test]
    fn culling_that_does_not_pay_is_skipped_ever_longer_and_taken_up_again() {
        let mut p = Payoff::new(COST);
        let loses = CullCounts { culled_triangles: 500, occluder_triangles: 300, tests: 100 };
        let mut culled = Vec::new();
        for f in 0..200 {
            if p.cull() {
                culled.push(f);
                p.judge(if f < 100 { loses } else { CullCounts { culled_triangles: 50_000, ..loses } });
            }
        }
        // Probes after 8, 32, 64 ... skipped frames; frame 107 pays.
        assert_eq!(&culled[..5], &[0, 9, 42, 107, 108]);
        // Once it pays again (from frame 100, found at the next probe) every frame culls.
        let back = culled.iter().position(|&f| f >= 100).unwrap();
        assert!(culled[back] <= 100 + MAX_SKIP as usize);
        assert_eq!(culled.len() - back, 200 - culled[back]);
    }

    #[test]
    fn the_cost_counts_occluders_and_tests() {
        let mut p = Payoff::new(COST);
        // 1000 + 2000 + 1000 = 4000 triangles' worth: 3999 culled does not pay.
        p.judge(CullCounts { culled_triangles: 3999, occluder_triangles: 2000, tests: 4000 });
        assert!(!p.cull());
        let mut p = Payoff::new(COST);
        p.judge(CullCounts { culled_triangles: 4000, occluder_triangles: 2000, tests: 4000 });
        assert!(p.cull());
    }

    #[test]
    fn the_two_parities_judge_apart() {
        let mut a = Alternating::new(COST);
        a.of(0).judge(CullCounts::default());
        assert!(!a.of(2).cull());
        assert!(a.of(1).cull());
    }
}
