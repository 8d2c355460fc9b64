"""The hub's dispatch modes by the names the commands take, as the FMU's parameters."""

N_MODULES = 25_000  # the paper's hub: 25 000 modules, about 60 MW
#: name -> the FMU's parameters: equal (every module the same share, all of them running) or
#: sequential (as few modules as possible at full power, the others in standby).
DISPATCHES = {
    "equal": dict(dispatch=1, belowMinimum=0),
    "sequential": dict(dispatch=2, belowMinimum=1),
}
