#!/usr/bin/env python3
"""The load patch's half-space compliances of numen's tissue contact (docs/tissue.md, "The
contact"; core/include/numen/core/net_tissue_contact.hpp, kPatchMeanCompliance).

A force F spread on an elastic half-space (plane-strain modulus E*) with the pressure
p(r) = F K(r/rho) / (2 pi rho^2 int_0^1 K(s) s ds), K(s) = (1 - s^2)^2, moves the surface by
w(r) = 1/(pi E*) int int p(s) / |r - s| dA (Boussinesq). This prints E* rho w(0) / F (the centre;
16 / (5 pi) in closed form) and E* rho int p w dA / F^2 (the pressure-weighted mean, what the
contact sees through the patch), by adaptive quadrature with the complete elliptic integral K:
int_0^{2 pi} dphi / |r - s| = 4 K(m) / (r + s), m = 4 r s / (r + s)^2.

    /usr/bin/python3 docs/figures/patch_compliance.py
"""
import math

from scipy import integrate
from scipy.special import ellipk


def main():
    norm = 2.0 * math.pi * integrate.quad(lambda s: (1.0 - s * s) ** 2 * s, 0.0, 1.0)[0]

    def p(s):
        return (1.0 - s * s) ** 2 / norm if s < 1.0 else 0.0

    def w(r):
        def f(s):
            return p(s) * s * 4.0 / (r + s) * ellipk(4.0 * r * s / (r + s) ** 2)
        return integrate.quad(f, 0.0, 1.0, points=[r] if 0.0 < r < 1.0 else None, limit=200)[0] / math.pi

    centre = 2.0 * integrate.quad(p, 0.0, 1.0)[0]
    mean = integrate.quad(lambda r: p(r) * w(r) * 2.0 * math.pi * r, 0.0, 1.0, limit=200)[0]
    print("centre compliance  E* rho w(0) / F       = %.7f (16 / (5 pi) = %.7f)" % (centre, 16.0 / (5.0 * math.pi)))
    print("mean compliance    E* rho <p w> / F^2    = %.7f" % mean)


if __name__ == "__main__":
    main()
