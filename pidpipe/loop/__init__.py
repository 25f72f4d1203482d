"""Close the loop: check the designs by DEM (:mod:`.verify`) and the C_eq model on a vibrating host."""
