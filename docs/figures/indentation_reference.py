#!/usr/bin/python3
"""Static reference for a rigid sphere pressed into a large elastic block (issue 67, figure 2).

Solved outside numen with GetFEM (Debian's python3-getfem), see docs/indentation-reference.md:
a rigid frictionless sphere of radius R = 5 mm pressed a depth delta (0 to 6 mm) into an elastic
cylinder of radius and height L (default 400 mm), bottom fixed, sides and top free. The problem is
axisymmetric: it is solved on the half-section (r, z) in [0, L] x [0, L], the weak form weighted
by r and the hoop strain u_r/r written out, P2 triangles on a mesh graded from the contact
(GetFEM's Bank refinement), the contact with the sphere exact (the gap of the displaced surface to
the sphere, frictionless) by an augmented Lagrangian (Alart-Curnier) on a P1 multiplier, Newton
with a line search, delta stepped with a linear predictor. Two laws, each fixed by E and nu:
  linear  small-strain linear elasticity (the contact kinematics exact);
  neo     compressible neo-Hookean, W = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2, whose small-
          strain limit is the linear law with the same E, nu.
For either law the force is E times a function of (nu, delta): the script reports F/E.

  /usr/bin/python3 docs/figures/indentation_reference.py            # table + checks, writes the CSV
  /usr/bin/python3 docs/figures/indentation_reference.py --quick    # Hertz at delta <= 0.1 R, coarse

Block mode (numen's material net, core/include/numen/core/net_material.hpp): the same sphere pressed
into a cylinder block of radius RB and height HB (mm), every boundary free but the contact, held
only by an elastic foundation in its volume, a body force -kappa u (reference volume),
kappa = E_net / l^2, E_net = (15/16) E / (1 - nu^2), l the support length:
  /usr/bin/python3 docs/figures/indentation_reference.py --block 30 30 --support-length 30 \
      [--nu 0.45] [--law linear|neo] [--stiffening B] [--net-continuum] [--mesh-scale S] [--out FILE.csv]
--net-continuum solves the continuum numen's net converges to: E_net and nu = 1/4 in place of E, nu
(kappa the same). F/E is always over the true E; Hertz alongside with E* = E / (1 - nu^2).

Law table (numen's tissue contact law, core/include/numen/core/net_tissue_contact.hpp): the
neo-Hookean half-space's g = F / (E* R^2) at delta / R = 0.02 ... 2 for nu = 0.2 ... 0.49, written
as the C++ header numen compiles (about 5 min; --table-nu NU prints one row and writes nothing):
  /usr/bin/python3 docs/figures/indentation_reference.py --law-table core/src/net/neo_hookean_sphere.hpp

Exit status: 0 checks passed, 1 a check failed, 77 python3-getfem (or numpy) missing (a skip).
"""
import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one thread: set before numpy and GetFEM load their libraries

import argparse
import math
import sys
import time

try:
    import numpy as np
    import getfem as gf
except ImportError as e:  # ctest reads 77 as a skip
    print(f"SKIP: {e} (Debian: apt-get install python3-getfem)")
    sys.exit(77)

R = 5.0  # sphere radius, mm
LAWS = ("linear", "neo")
NUS = (0.3, 0.45, 0.49)
# Depths reported (mm): steps of 0.02 R up to 0.1 R, then coarser.
DELTAS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0)
TOP, BOTTOM, AXIS, CONTACT = 1, 2, 3, 4


def hertz(delta, nu):
    """Hertz, F/E in mm^2: 4/3 / (1 - nu^2) sqrt(R) delta^1.5."""
    return 4.0 / 3.0 / (1.0 - nu * nu) * math.sqrt(R) * delta ** 1.5


def sneddon(delta, nu):
    """Sneddon's exact sphere on a half-space (linear, linearized contact geometry), F/E in mm^2:
    delta = a/2 ln((R+a)/(R-a)), F = E*/2 [(a^2 + R^2) ln((R+a)/(R-a)) - 2 a R]."""
    lo, hi = 0.0, R
    for _ in range(200):  # bisection on the contact radius a
        a = 0.5 * (lo + hi)
        if 0.5 * a * math.log((R + a) / (R - a)) < delta:
            lo = a
        else:
            hi = a
    a = 0.5 * (lo + hi)
    return 0.5 / (1.0 - nu * nu) * ((a * a + R * R) * math.log((R + a) / (R - a)) - 2.0 * a * R)


def graded_mesh(L, s, h0=0.25, grade=0.25, patch=8.0, H=None):
    """Triangles on [0, L] x [0, H] (r, z; H = L when not given), refined (Bank) until every
    triangle's diameter is at most h(x) = s (h0 + grade * dist(x, contact patch)), the patch being
    the top segment r <= patch (mm) at z = H. s scales the whole size field: s = 1/2 halves every
    element."""
    H = L if H is None else H
    m = gf.Mesh("regular simplices", np.linspace(0.0, L, 5), np.linspace(0.0, H, 5))
    for _ in range(100):
        cv = m.cvid()
        ids, idx = m.pid_from_cvid(cv)
        P = m.pts()[:, ids].reshape(2, -1, 3)  # every triangle has 3 points: (2, ncv, 3)
        cen = P.mean(axis=2)
        diam = np.max([np.hypot(*(P[:, :, i] - P[:, :, j])) for i, j in ((0, 1), (1, 2), (0, 2))], axis=0)
        dist = np.hypot(np.maximum(cen[0] - patch, 0.0), H - cen[1])
        big = cv[diam > s * (h0 + grade * dist)]
        if len(big) == 0:
            return m
        m.refine(big)
    raise RuntimeError("mesh refinement did not finish")


class Indentation:
    """One block, one law, one nu: the model, stepped in delta. The block is a cylinder of radius
    L and height H (mm; H = L when not given). kappa None: bottom fixed (the reference table);
    kappa > 0 (E/mm^2): no fixed boundary, an elastic foundation -kappa u in the volume instead."""

    def __init__(self, law, nu, E=1.0, L=400.0, s=1.0, contact="exact", rc=10.0, H=None, kappa=None, b=0.0):
        H = L if H is None else H
        self.law, self.nu, self.E, self.L, self.H, self.s, self.kappa = law, nu, E, L, H, s, kappa
        m = self.mesh = graded_mesh(L, s, H=H)
        m.set_region(TOP, m.outer_faces_with_direction([0.0, 1.0], 0.01))
        m.set_region(BOTTOM, m.outer_faces_with_direction([0.0, -1.0], 0.01))
        m.set_region(AXIS, m.outer_faces_with_direction([-1.0, 0.0], 0.01))
        # Faces that may touch the sphere: the top out to rc (the contact never reaches r = R).
        m.set_region(CONTACT, m.outer_faces_in_box([-1.0, H - 1e-9], [min(rc, L), H + 1.0]))
        mf = gf.MeshFem(m, 1)  # u_r and u_z: two scalar P2 fields (u_r = 0 on the axis)
        mf.set_classical_fem(2)
        mfp = self.mfp = gf.MeshFem(m, 1)  # contact pressure: P1 on the contact faces
        mfp.set_classical_fem(1)
        mim = self.mim = gf.MeshIm(m, 5)  # P2 x P2 x r: degree 5 exact on straight triangles
        md = self.md = gf.Model("real")
        md.add_fem_variable("ur", mf)
        md.add_fem_variable("uz", mf)
        md.add_filtered_fem_variable("p", mfp, CONTACT)
        lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        mu = E / (2.0 * (1.0 + nu))
        md.add_initialized_data("lambda", lam)
        md.add_initialized_data("mu", mu)
        md.add_macro("r", "X(1)")
        md.add_macro("G", "[Grad_ur(1), Grad_ur(2); Grad_uz(1), Grad_uz(2)]")  # d(u_r,u_z)/d(r,z)
        # Weak form per radian: int (S : grad v + S_tt v_r / r) r dr dz, S the stress's (r,z)
        # block, S_tt its hoop component (Cauchy = first Piola for the linear law).
        if law == "linear":
            md.add_macro("tr", "Trace(G) + ur/r")
            md.add_macro("S", "lambda*tr*Id(2) + mu*(G + G')")
            md.add_macro("Stt", "lambda*tr + 2*mu*ur/r")
            md.add_linear_term(mim, "r*(S(1,:).Grad_Test_ur + S(2,:).Grad_Test_uz) + Stt*Test_ur")
        elif law == "neo":
            # F = diag(F2, Ftt); P = mu (F - F^-T) + lambda ln J F^-T.
            md.add_macro("F2", "Id(2) + G")
            md.add_macro("Ftt", "1 + ur/r")
            md.add_macro("J", "Det(F2)*Ftt")
            # Stiffening b: mu times exp(b Q), Q = I1 - 3 - 2 ln J (b = 0: the law above).
            md.add_initialized_data("b", b)
            md.add_macro("Q", "Norm_sqr(F2) + Ftt*Ftt - 3 - 2*log(J)")
            md.add_macro("mub", "mu*exp(b*Q)")
            md.add_macro("S", "mub*(F2 - Inv(F2)') + lambda*log(J)*Inv(F2)'")
            md.add_macro("Stt", "mub*(Ftt - 1/Ftt) + lambda*log(J)/Ftt")
            md.add_nonlinear_term(mim, "r*(S(1,:).Grad_Test_ur + S(2,:).Grad_Test_uz) + Stt*Test_ur")
        else:
            raise ValueError(law)
        if kappa is None:
            md.add_Dirichlet_condition_with_simplification("ur", BOTTOM)
            md.add_Dirichlet_condition_with_simplification("uz", BOTTOM)
        else:  # the foundation per radian: int kappa u.v r dr dz (reference volume, any law)
            md.add_initialized_data("kappa", kappa)
            md.add_linear_term(mim, "r*kappa*(ur*Test_ur + uz*Test_uz)")
        md.add_Dirichlet_condition_with_simplification("ur", AXIS)
        # The sphere: centre (0, zc), zc = H + R - delta.
        md.add_initialized_data("zc", H + R)
        md.add_initialized_data("Rs", R)
        md.add_initialized_data("ra", E / (s * 0.25))  # augmentation ~ E / h at the contact
        if contact == "exact":  # gap and normal of the displaced point to the sphere
            md.add_macro("dx", "[r + ur; X(2) + uz - zc]")
            md.add_macro("gap", "Norm(dx) - Rs")
            md.add_macro("Nn", "dx/Norm(dx)")
        elif contact == "linearized":  # Sneddon's: the vertical gap at the undeformed radius
            md.add_macro("gap", "zc - sqrt(pos_part(Rs*Rs - r*r)) - X(2) - uz")
            md.add_macro("Nn", "[0; -1]")
        else:
            raise ValueError(contact)
        # Alart-Curnier: pressure Pc = max(0, p - ra gap) pushes the body along Nn; the second
        # term makes p = Pc, i.e. p >= 0, gap >= 0, p gap = 0.
        md.add_macro("Pc", "pos_part(p - ra*gap)")
        md.add_nonlinear_term(mim, "-r*Pc*(Nn(1)*Test_ur + Nn(2)*Test_uz)", CONTACT)
        md.add_nonlinear_term(mim, "r/ra*(p - Pc)*Test_p", CONTACT)
        self.delta = 0.0
        self.state = self._get()
        self.prev = None  # (delta, state) one converged step back, for the predictor
        self.iterations = 0
        self.newton_calls = 0

    def _get(self):
        return {v: self.md.variable(v).copy() for v in ("ur", "uz", "p")}

    def _set(self, st):
        for v, x in st.items():
            self.md.set_variable(v, x)

    def _try(self, delta):
        """One Newton solve at delta from a linear predictor; True if it converged."""
        if self.prev is not None:
            d0, st0 = self.prev
            w = (delta - self.delta) / (self.delta - d0)
            self._set({v: self.state[v] + w * (self.state[v] - st0[v]) for v in self.state})
        else:
            self._set(self.state)
        self.md.set_variable("zc", [self.H + R - delta])
        try:
            it, conv = self.md.solve("max_iter", 25, "max_res", 1e-9 * self.E, "lsearch", "simplest",
                                     "lsolver", "mumps")
        except RuntimeError:  # e.g. J <= 0 in a trial state
            return False
        self.newton_calls += 1
        self.iterations += it
        ok = bool(conv) and all(np.all(np.isfinite(self.md.variable(v))) for v in ("ur", "uz", "p"))
        return ok

    def step_to(self, target, max_step=0.25):
        """Move the sphere down to `target` (mm) in steps of at most max_step, halving on failure."""
        h = max_step
        while self.delta < target - 1e-12:
            d = min(target, self.delta + h)
            if target - d < 0.2 * h:  # no sliver of a last step
                d = target
            if self._try(d):
                self.prev = (self.delta, self.state)
                self.delta, self.state = d, self._get()
                h = min(max_step, 1.5 * h)
            else:
                self._set(self.state)
                h *= 0.5
                if h < 1e-3:
                    raise RuntimeError(f"{self.law} nu={self.nu}: no convergence beyond delta={self.delta}")

    def force_over_E(self):
        """F/E (mm^2): the sphere's push on the body, 2 pi int Pc (-Nn_z) r ds over the contact."""
        f = -2.0 * math.pi * gf.asm_generic(self.mim, 0, "r*Pc*Nn(2)", CONTACT, self.md)
        return f / self.E

    def contact_radius(self):
        """Largest displaced radius of a contact-face vertex touching the sphere (gap below
        1e-4 mm), in mm, to the mesh size there (0.25 mm at s = 1)."""
        nodes = self.mfp.basic_dof_nodes(self.mfp.basic_dof_on_region(CONTACT))
        gap = self.md.interpolation("gap", nodes, self.mesh)
        on = nodes[:, gap < 1e-4]
        if on.shape[1] == 0:
            return 0.0
        return float(np.max(on[0] + self.md.interpolation("ur", on, self.mesh)))

    def sweep(self, deltas=DELTAS, max_step=None):
        """F/E and contact radius at each delta: {delta: (F/E, a)}. Steps of at most 0.5 mm for
        the linear law, 0.25 mm for the neo-Hookean one (whose Newton needs them at nu = 0.49),
        halved on the finer mesh (s < 1)."""
        if max_step is None:
            max_step = 0.5 if self.law == "linear" else 0.25 * min(1.0, self.s)
        out = {}
        for d in deltas:
            self.step_to(d, max_step)
            out[d] = (self.force_over_E(), self.contact_radius())
        return out


def pct(a, b):
    return 100.0 * (a / b - 1.0)


def run(law, nu, deltas, **kw):
    t = time.time()
    ind = Indentation(law, nu, **kw)
    res = ind.sweep(deltas)
    dt = time.time() - t
    size = f"L={ind.L:g}" if ind.kappa is None else f"block {ind.L:g}x{ind.H:g} kappa={ind.kappa:.4g}"
    print(f"  {law:6s} nu={nu:<4} {size} {kw.get('contact', 'exact'):10s} dofs={ind.md.nbdof():6d}"
          f" cells={ind.mesh.nbcvs():5d} Newton {ind.iterations:3d} it in {ind.newton_calls:3d} solves,"
          f" {dt:5.1f} s", flush=True)
    return res


def net_modulus(E, nu):
    """numen's net modulus E_net = (15/16) E / (1 - nu^2) (net_material.hpp, its affine
    correction 1): a continuum of (E_net, 1/4) has the plane-strain modulus E / (1 - nu^2)."""
    return 15.0 / 16.0 * E / (1.0 - nu * nu)


def block(args):
    """The block mode: F/E at DELTAS in a free cylinder block held by the volumetric foundation."""
    rb, hb = args.block
    ell, nu, E = args.support_length, args.nu, 1.0
    if not (rb > 0.0 and hb > 0.0 and ell > 0.0 and -1.0 < nu < 0.5):
        print("block: need RADIUS_MM, HEIGHT_MM, --support-length > 0 and --nu in (-1, 0.5)")
        return 2
    e_net = net_modulus(E, nu)
    kappa = e_net / (ell * ell)  # E/mm^2
    # The solved continuum: the material itself, or the one numen's net converges to.
    e_solved, nu_solved = (e_net, 0.25) if args.net_continuum else (E, nu)
    model = "net-continuum" if args.net_continuum else "material"
    t0 = time.time()
    print(f"block {rb:g} x {hb:g} mm (radius x height), support length {ell:g} mm, kappa = {kappa:.6g} E/mm^2;"
          f" {args.law}, {model}: E_solved = {e_solved:.6g} E, nu_solved = {nu_solved:g}; mesh scale {args.mesh_scale:g}")
    if args.stiffening != 0.0 and args.law != "neo":
        print("block: --stiffening needs --law neo")
        return 2
    res = run(args.law, nu_solved, DELTAS, E=e_solved, L=rb, H=hb, s=args.mesh_scale, kappa=kappa,
              b=args.stiffening)
    dt = time.time() - t0
    rows = [(d, res[d][0] * e_solved / E, hertz(d, nu)) for d in DELTAS]
    print("  delta_mm   F/E_mm2    Hertz   vs Hertz")
    for d, f, h in rows:
        print(f"  {d:6.2f}  {f:9.5f}  {h:9.5f}  {pct(f, h):+7.2f} %")
    if args.out:
        with open(args.out, "w") as out:
            out.write("# Rigid frictionless sphere (R = 5 mm) pressed delta into a free cylinder block held by an\n"
                      "# elastic foundation in its volume (body force -kappa u, kappa = E_net / l^2,\n"
                      "# E_net = (15/16) E / (1 - nu^2)), static, GetFEM (docs/figures/indentation_reference.py\n"
                      "# --block, docs/indentation-reference.md). Command:\n"
                      f"#   /usr/bin/python3 docs/figures/indentation_reference.py {' '.join(sys.argv[1:])}\n"
                      f"# block radius {rb:g} mm, height {hb:g} mm, support length l = {ell:g} mm, law {args.law}"
                      f" (stiffening b = {args.stiffening:g}),\n"
                      f"# model {model}: solved with E_solved = {e_solved:.6g} E, nu_solved = {nu_solved:g}\n"
                      "# (material: the true E, nu; net-continuum: E_net and 1/4, what numen's net converges to).\n"
                      "# force_over_E_mm2 = F/E over the TRUE E, in mm^2: F[N] = E[MPa] * value = E[kPa] * 1e-3 * value.\n"
                      "# hertz_over_E_mm2 = 4/3 / (1 - nu^2) * sqrt(R) * delta^1.5 (true nu; same units).\n")
            out.write("law,model,nu,block_radius_mm,block_height_mm,support_length_mm,delta_mm,"
                      "force_over_E_mm2,hertz_over_E_mm2\n")
            for d, f, h in rows:
                out.write(f"{args.law},{model},{nu},{rb:g},{hb:g},{ell:g},{d},{f:.6g},{h:.6g}\n")
        print(f"wrote {args.out}")
    print(f"block: done in {dt:.1f} s")
    return 0


# The law table (--law-table): the half-space's F / (E* R^2) against delta / R, which numen's
# tissue contact law reads (core/src/net/neo_hookean_sphere.hpp). Half-space: F / E is R^2 times a
# function of delta / R, nu and the stiffening b alone (no other length), so one R serves every
# sphere. b = 0 is the neo-Hookean law; b > 0 its exponential (Demiray) stiffening.
TABLE_BS = (0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0)
TABLE_NUS = (0.2, 0.3, 0.4, 0.45, 0.49)
TABLE_X = (0.02, 0.04, 0.06, 0.08, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0,
           1.2, 1.4, 1.6, 1.8, 2.0)


def table_row(b, nu, s):
    """g = F / (E* R^2) at TABLE_X for one (b, nu), printed with its ratio to Hertz."""
    gf.util_trace_level(0)
    res = run("neo", nu, tuple(x * R for x in TABLE_X), rc=20.0, s=s, b=b)
    row = [res[x * R][0] * (1.0 - nu * nu) / (R * R) for x in TABLE_X]
    lines = [f"  b={b:g} nu={nu:g}:  x  g=F/(E* R^2)  Hertz 4/3 x^1.5  ratio"]
    for x, g in zip(TABLE_X, row):
        h = 4.0 / 3.0 * x ** 1.5
        lines.append(f"  {x:4.2f}   {g:11.6f}   {h:11.6f}   {g / h:7.4f}")
    print("\n".join(lines), flush=True)
    return row


def law_table(args):
    """Writes the C++ header of the half-space table: for each b of TABLE_BS and nu of TABLE_NUS
    the dimensionless force g = F / (E* R^2), E* = E / (1 - nu^2), at delta / R = TABLE_X
    (L = 400 mm, fixed bottom, the exact contact; 80 contact radii: check 4's 0.4 %), the rows
    solved by --jobs processes."""
    from concurrent.futures import ProcessPoolExecutor
    t0 = time.time()
    if args.table_nu is not None:
        table_row(args.stiffening, args.table_nu, args.mesh_scale)
        return 0
    keys = [(b, nu) for b in TABLE_BS for nu in TABLE_NUS]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = {k: pool.submit(table_row, k[0], k[1], args.mesh_scale) for k in keys}
        rows = {k: f.result() for k, f in futures.items()}
    with open(args.law_table, "w") as out:
        out.write("#pragma once\n"
                  "/// @file neo_hookean_sphere.hpp\n"
                  "/// GENERATED by docs/figures/indentation_reference.py --law-table (GetFEM, docs/indentation-reference.md,\n"
                  "/// \"The law table\"); do not edit. A rigid frictionless sphere of radius R pressed delta into a\n"
                  "/// compressible neo-Hookean half-space with exponential (Demiray) stiffening b,\n"
                  "/// W = mu/(2b) (exp(b Q) - 1) + lambda/2 (ln J)^2, Q = I1 - 3 - 2 ln J (b = 0: W = mu/2 Q + lambda/2 (ln J)^2,\n"
                  f"/// the compressible neo-Hookean law), a cylinder of 400 mm = {400.0 / R:g} R, fixed bottom; statically, exact\n"
                  "/// contact kinematics, frictionless: g = F / (E* R^2), E* = E / (1 - nu^2), at x = delta / R, for each b and\n"
                  "/// nu. Hertz is g = 4/3 x^1.5.\n"
                  "\n"
                  "namespace numen::core::detail {\n\n"
                  f"inline constexpr int kNeoHookeanSphereStiffenings = {len(TABLE_BS)};\n"
                  f"inline constexpr int kNeoHookeanSphereNus = {len(TABLE_NUS)};\n"
                  f"inline constexpr int kNeoHookeanSpherePoints = {len(TABLE_X)};\n"
                  "/// Stiffenings b of the blocks, increasing from 0.\n"
                  "inline constexpr double kNeoHookeanSphereB[kNeoHookeanSphereStiffenings] = {"
                  + ", ".join(f"{b:g}" for b in TABLE_BS) + "};\n"
                  "/// Poisson's ratios of the rows, increasing.\n"
                  "inline constexpr double kNeoHookeanSphereNu[kNeoHookeanSphereNus] = {"
                  + ", ".join(f"{nu:g}" for nu in TABLE_NUS) + "};\n"
                  "/// x = delta / R of the columns, increasing.\n"
                  "inline constexpr double kNeoHookeanSphereX[kNeoHookeanSpherePoints] = {"
                  + ", ".join(f"{x:g}" for x in TABLE_X) + "};\n"
                  "/// g = F / (E* R^2) [b][nu][x].\n"
                  "inline constexpr double kNeoHookeanSphereG[kNeoHookeanSphereStiffenings][kNeoHookeanSphereNus]"
                  "[kNeoHookeanSpherePoints] = {\n")
        for b in TABLE_BS:
            out.write("  {\n")
            for nu in TABLE_NUS:
                out.write("    {" + ", ".join(f"{g:.7g}" for g in rows[(b, nu)]) + "},\n")
            out.write("  },\n")
        out.write("};\n\n}  // namespace numen::core::detail\n")
    print(f"wrote {args.law_table} in {time.time() - t0:.1f} s")
    return 0


def quick():
    """Coarse mesh (s = 2), both laws, nu = 0.3 and 0.49: F within 5 % of Hertz at delta <= 0.1 R."""
    ok = True
    print("quick: F/E against Hertz at delta <= 0.1 R, coarse mesh (s = 2)")
    for law in LAWS:
        for nu in (0.3, 0.49):
            res = run(law, nu, DELTAS[:5], s=2.0)
            for d, (f, _) in res.items():
                e = pct(f, hertz(d, nu))
                bad = abs(e) > 5.0
                ok &= not bad
                print(f"    delta={d:.1f} mm  F/E={f:.5f}  Hertz={hertz(d, nu):.5f}  {e:+.2f} %"
                      f"{'  FAIL (> 5 %)' if bad else ''}")
    return ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse Hertz check only (< 60 s)")
    ap.add_argument("--csv", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                  "indentation_reference.csv"))
    blk = ap.add_argument_group("block mode (numen's material net: free block, volumetric foundation)")
    blk.add_argument("--block", nargs=2, type=float, metavar=("RADIUS_MM", "HEIGHT_MM"),
                     help="solve the free cylinder block of this radius and height instead of the table")
    blk.add_argument("--support-length", type=float, metavar="L_MM",
                     help="support length l: foundation kappa = (15/16) E / (1 - nu^2) / l^2")
    blk.add_argument("--nu", type=float, default=0.45, help="the material's Poisson ratio (0.45)")
    blk.add_argument("--law", choices=LAWS, default="linear")
    blk.add_argument("--net-continuum", action="store_true",
                     help="solve with E_net and nu = 1/4 (what numen's net converges to)")
    blk.add_argument("--mesh-scale", type=float, default=1.0, help="size field factor s (1)")
    blk.add_argument("--out", help="CSV to write (block mode)")
    tab = ap.add_argument_group("law table (numen's tissue contact law)")
    tab.add_argument("--law-table", metavar="HEADER", help="write the neo-Hookean half-space table as a C++ header")
    tab.add_argument("--table-nu", type=float, help="solve and print one nu's row only (writes nothing)")
    tab.add_argument("--stiffening", type=float, default=0.0,
                     help="the neo-Hookean law's stiffening b (0), for --table-nu and --block")
    tab.add_argument("--jobs", type=int, default=2, help="processes solving the table's rows (2)")
    args = ap.parse_args()
    if args.block is None and (args.support_length is not None or args.net_continuum or args.out):
        ap.error("--support-length, --net-continuum and --out need --block")
    if args.block is not None and (args.support_length is None or args.quick):
        ap.error("--block needs --support-length and excludes --quick")
    gf.util_trace_level(0)
    if args.law_table is not None or args.table_nu is not None:
        return law_table(args)
    if args.block is not None:
        return block(args)
    t0 = time.time()
    if args.quick:
        ok = quick()
        print(f"quick: {'PASS' if ok else 'FAIL'} in {time.time() - t0:.1f} s")
        return 0 if ok else 1
    ok = True

    print("Reference table: L = 400 mm, default mesh (s = 1)")
    table = {(law, nu): run(law, nu, DELTAS) for law in LAWS for nu in NUS}

    print("\nCheck 1, Hertz (linear law, delta <= 0.1 R): FE against Hertz and against Sneddon's exact"
          " sphere (which linearizes the contact geometry)")
    for nu in NUS:
        for d in DELTAS[:5]:
            f = table[("linear", nu)][d][0]
            e = pct(f, hertz(d, nu))
            ok &= abs(e) <= 5.0
            print(f"  nu={nu:<4} delta={d:.1f}  F/E={f:.5f}  Hertz {hertz(d, nu):.5f} ({e:+.2f} %)"
                  f"  Sneddon {sneddon(d, nu):.5f} ({pct(f, sneddon(d, nu)):+.2f} %)")

    print("\nCheck 2, the FE alone: linear law with Sneddon's linearized contact geometry, nu = 0.3")
    res = run("linear", 0.3, DELTAS[:5], contact="linearized")
    for d, (f, _) in res.items():
        e = pct(f, sneddon(d, 0.3))
        ok &= abs(e) <= 1.0
        print(f"  delta={d:.1f}  F/E={f:.5f}  Sneddon {sneddon(d, 0.3):.5f} ({e:+.2f} %)")

    print("\nCheck 3, mesh convergence, nu = 0.49 (the worst case): the size field times s = 2, 1"
          " (the table's) and 1/2; s = 1/2 up to delta = 0.6 R only")
    for law in LAWS:
        f = {1.0: {d: v[0] for d, v in table[(law, 0.49)].items()},
             2.0: {d: v[0] for d, v in run(law, 0.49, DELTAS, s=2.0).items()},
             0.5: {d: v[0] for d, v in run(law, 0.49, (0.5, 3.0), s=0.5).items()}}
        for d in (0.5, 3.0, 6.0):
            if d in f[0.5]:
                e = pct(f[1.0][d], f[0.5][d])
                ok &= abs(e) <= 2.0
                print(f"    {law:6s} delta={d:.1f}  s=2 {f[2.0][d]:.5f}  s=1 {f[1.0][d]:.5f}  s=1/2 {f[0.5][d]:.5f}"
                      f"   s=1 vs s=1/2 {e:+.3f} %  s=2 vs s=1/2 {pct(f[2.0][d], f[0.5][d]):+.3f} %")
            else:
                print(f"    {law:6s} delta={d:.1f}  s=2 {f[2.0][d]:.5f}  s=1 {f[1.0][d]:.5f}"
                      f"   s=2 vs s=1 {pct(f[2.0][d], f[1.0][d]):+.3f} %")

    print("\nCheck 4, block size: L = 400 mm against 800 mm (and 60 mm, about 10 contact radii), nu = 0.45")
    for law in LAWS:
        big = run(law, 0.45, DELTAS, L=800.0)
        small = run(law, 0.45, DELTAS, L=60.0)
        worst = 0.0
        for d in DELTAS:
            f = table[(law, 0.45)][d][0]
            e = pct(f, big[d][0])
            worst = max(worst, abs(e))
            if d in (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0):
                print(f"    {law:6s} delta={d:.1f}  L=60 {small[d][0]:.5f} ({pct(small[d][0], big[d][0]):+.2f} %)"
                      f"  L=400 {f:.5f} ({e:+.2f} %)  L=800 {big[d][0]:.5f}")
        ok &= worst <= 1.0
        print(f"    {law:6s} largest |L=400 vs L=800| over all delta: {worst:.2f} %")

    print("\nCheck 5, F proportional to E: neo-Hookean nu = 0.45, E = 1 MPa against E = 5 kPa")
    other = run("neo", 0.45, (0.5, 3.0), E=0.005)
    for d in (0.5, 3.0):
        e = pct(other[d][0], table[("neo", 0.45)][d][0])
        ok &= abs(e) <= 1e-3
        print(f"    delta={d:.1f}  F/E at E=1 MPa {table[('neo', 0.45)][d][0]:.6f},"
              f" at E=5 kPa {other[d][0]:.6f} ({e:+.1e} %)")

    amax = max(v[1] for res in table.values() for v in res.values())
    print(f"\nLargest contact radius (displaced, to ~0.25 mm): {amax:.2f} mm (a point on the sphere is"
          f" within R = {R:g} mm of the axis); L = 400 mm is {400.0 / amax:.0f} times it")

    with open(args.csv, "w") as out:
        out.write("# Rigid frictionless sphere (R = 5 mm) pressed delta into an elastic block\n"
                  "# (cylinder of radius and height 400 mm, bottom fixed, sides free), static, GetFEM\n"
                  "# (docs/figures/indentation_reference.py, docs/indentation-reference.md).\n"
                  "# law: linear = small-strain linear elasticity, neo = compressible neo-Hookean\n"
                  "# W = mu/2 (I1-3) - mu ln J + lambda/2 (ln J)^2; nu = Poisson's ratio.\n"
                  "# force_over_E_mm2 = F/E in mm^2: F[N] = E[MPa] * value = E[kPa] * 1e-3 * value.\n"
                  "# hertz_over_E_mm2 = 4/3 / (1 - nu^2) * sqrt(R) * delta^1.5 (same units).\n")
        out.write("law,nu,delta_mm,force_over_E_mm2,hertz_over_E_mm2\n")
        for (law, nu), res in table.items():
            for d in DELTAS:
                out.write(f"{law},{nu},{d},{res[d][0]:.6g},{hertz(d, nu):.6g}\n")
    print(f"\nwrote {args.csv}")

    print("\nF/E (mm^2) at the depths of the table:")
    show = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    print("  law    nu    " + "".join(f"{d:>9.1f}" for d in show))
    for (law, nu), res in table.items():
        print(f"  {law:6s} {nu:<5} " + "".join(f"{res[d][0]:9.4f}" for d in show))
    print("  Hertz  0.3   " + "".join(f"{hertz(d, 0.3):9.4f}" for d in show))
    print(f"\n{'PASS' if ok else 'FAIL'}: all checks, {time.time() - t0:.0f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
