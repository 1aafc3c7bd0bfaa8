"""Numbers the seed paper states (``../shared/seed``: *Simulation of the Effects of Backlash on the Performance of a
Collaborative Robot*), used as defaults and reference marks wherever ur5fault compares with it: one name each."""

#: backlash the paper finds acceptable for its pick-and-place [deg] (the backlash of its Fig. 3) ...
PAPER_BACKLASH_DEG = 0.1
#: ... at this largest TCP deviation [mm]: its acceptability threshold (a campaign's default ``threshold_mm``, a life
#: fleet's default failure threshold on ``tcp_dev_max_mm``)
PAPER_TCP_MM = 0.5
