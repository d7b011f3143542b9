Œ4Vxi0
sY3Z(gŒ4Vxi0
sY3Z(d‰€4Vx„4Vxi0
€ˆ4VxsY3Z(fˆ‚4VxÜ9