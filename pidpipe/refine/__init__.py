"""The design-driven refinement: the campaign spends engine CPU where the designs are uncertain.

:mod:`.loop` runs the rounds (engine-free: the engine, the verifying runs and the cost model are
callables); :mod:`.table` keeps the append-only table that is the loop's state; :mod:`.intervals`
takes each design's 95 % interval from the surrogate; :mod:`.candidates` lists what may run;
:mod:`.choice` chooses a round's cases; :mod:`.verification` compares the verifying runs with the
surrogate; :mod:`.outputs` writes the files; :mod:`.campaign` binds the loop to them (resuming
from the table it wrote).
"""
