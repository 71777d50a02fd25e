//! The sampler's schedule (Calder section 3.4): generations, particle
//! counts ramped linearly from a start to an end value, and the heuristic
//! scale ramped linearly to zero.

use grm_sema::Settings;

/// How many generations to run, with how many particles, and how much
/// heuristic. Every value can be overridden; the defaults are Calder's
/// playground defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    /// Generations of the skeleton phase (at least 1).
    pub generations: u32,
    /// Particles in the first generation.
    pub particles_start: u32,
    /// Particles in the last generation.
    pub particles_end: u32,
    /// `HEURISTICSCALE` at generation 0.
    pub heuristic_scale: f64,
    /// The generation from which the heuristic scale is 0 (linear ramp from
    /// `heuristic_scale` at generation 0). 0 turns the heuristic off.
    pub heuristic_until: u32,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule::calder_playground()
    }
}

impl Schedule {
    /// Calder's playground defaults: 100 generations, particles ramped
    /// linearly from 100 to 15, heuristic scale 0.013 ramped to 0 by
    /// generation 40.
    pub fn calder_playground() -> Schedule {
        Schedule {
            generations: 100,
            particles_start: 100,
            particles_end: 15,
            heuristic_scale: 0.013,
            heuristic_until: 40,
        }
    }

    /// The calder library's own default for `generateSOSMC`: 10
    /// generations ("depth") of 50 particles, with the playground's
    /// heuristic ramp scaled to the shorter run (0.013 to 0 by generation 4).
    pub fn calder_library() -> Schedule {
        Schedule {
            generations: 10,
            particles_start: 50,
            particles_end: 50,
            heuristic_scale: 0.013,
            heuristic_until: 4,
        }
    }

    /// The playground schedule with a system's `generations`,
    /// `particles_start` and `particles_end` settings (whose defaults are
    /// the same values); the heuristic ramp ends at 40% of the run, as in
    /// the playground (40 of 100).
    pub fn from_settings(s: &Settings) -> Schedule {
        let generations = s.generations.max(1);
        Schedule {
            generations,
            particles_start: s.particles_start.max(1),
            particles_end: s.particles_end.max(1),
            heuristic_scale: 0.013,
            heuristic_until: ((u64::from(generations) * 2).div_ceil(5)) as u32,
        }
    }

    /// The same schedule over `generations` generations (at least 1), the
    /// heuristic ramp again ending at 40% of the run (`grmc sample
    /// --generations`).
    pub fn with_generations(mut self, generations: u32) -> Schedule {
        self.generations = generations.max(1);
        self.heuristic_until = ((u64::from(self.generations) * 2).div_ceil(5)) as u32;
        self
    }

    /// The same schedule without the heuristic.
    pub fn without_heuristic(mut self) -> Schedule {
        self.heuristic_scale = 0.0;
        self.heuristic_until = 0;
        self
    }

    /// Particles in generation `g` (0-based): the linear ramp from
    /// `particles_start` to `particles_end`, rounded to nearest, at least 1.
    pub fn particles(&self, g: u32) -> usize {
        let a = f64::from(self.particles_start.max(1));
        let b = f64::from(self.particles_end.max(1));
        let last = self.generations.max(1) - 1;
        if last == 0 {
            return a as usize;
        }
        let t = f64::from(g.min(last)) / f64::from(last);
        (a + (b - a) * t).round().max(1.0) as usize
    }

    /// `HEURISTICSCALE` in generation `g`: `heuristic_scale * (1 - g /
    /// heuristic_until)` while positive, then 0.
    pub fn heuristic_scale(&self, g: u32) -> f64 {
        if self.heuristic_until == 0 || g >= self.heuristic_until {
            return 0.0;
        }
        self.heuristic_scale * (1.0 - f64::from(g) / f64::from(self.heuristic_until))
    }

    /// Particle steps over the whole run (the sum of [`Self::particles`]).
    pub fn total_steps(&self) -> u64 {
        (0..self.generations.max(1))
            .map(|g| self.particles(g) as u64)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn playground_ramps() {
        let s = Schedule::calder_playground();
        assert_eq!(s.particles(0), 100);
        assert_eq!(s.particles(99), 15);
        assert_eq!(s.particles(200), 15);
        assert!(s.particles(50) < 100 && s.particles(50) > 15);
        assert!((0..99).all(|g| s.particles(g) >= s.particles(g + 1)));
        assert_eq!(s.heuristic_scale(0), 0.013);
        assert!((s.heuristic_scale(20) - 0.0065).abs() < 1e-12);
        assert_eq!(s.heuristic_scale(40), 0.0);
        assert_eq!(s.heuristic_scale(99), 0.0);
        assert_eq!(s.without_heuristic().heuristic_scale(0), 0.0);
        // 100 + ... + 15 over a linear ramp: about 57.5 a generation.
        assert!(
            (5700..5800).contains(&s.total_steps()),
            "{}",
            s.total_steps()
        );
    }

    #[test]
    fn fewer_generations_shorten_the_heuristic_ramp() {
        let s = Schedule::calder_playground().with_generations(3);
        assert_eq!((s.generations, s.heuristic_until), (3, 2));
        assert_eq!(s.particles_start, 100);
        let s = s.with_generations(0);
        assert_eq!((s.generations, s.heuristic_until), (1, 1));
        assert_eq!(
            Schedule::calder_playground().with_generations(100),
            Schedule::calder_playground()
        );
    }

    #[test]
    fn settings_give_the_same_defaults() {
        assert_eq!(
            Schedule::from_settings(&Settings::default()),
            Schedule::calder_playground()
        );
        let one = Schedule {
            generations: 1,
            ..Schedule::calder_library()
        };
        assert_eq!(one.particles(0), 50);
    }
}
