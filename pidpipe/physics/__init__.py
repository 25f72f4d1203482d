"""The physics every stage shares: contact mechanics (Hertz, Tsuji damping, Rayleigh time) and the equivalent damping."""
