"""Everything that runs LIGGGHTS: decks, the process, its output, pouring, shaking a case, patches, impacts."""
