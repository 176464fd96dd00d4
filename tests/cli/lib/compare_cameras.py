"""Compares the cameras of two COLMAP text models up to a similarity transform (scene colmap's
test): the relative rotation R_i R_j^T of every pair of cameras (unchanged by a change of world
frame), and the camera centres after the similarity that the rotations and a least-squares
scale give, in shares of the known cameras' extent (the largest distance of a centre from their
mean). The medians must be within MAX_DEG / MAX_SHARE and the worst within WORST_FACTOR times
them: COLMAP's mapper is not deterministic with several threads, and on 24 photos of 256x144 it
now and then bends the path by a few degrees (18 runs on livingroom: medians 0.48-1.79 deg and
1.07-1.44 %, worst 1.06-5.34 deg and 1.92-3.17 %), while a wrong convention (a transposed
rotation, a flipped axis) costs tens of degrees. Prints the errors; exits 1 when a tolerance
is broken.
Usage: python3 compare_cameras.py KNOWN/images.txt RECOVERED/images.txt MAX_DEG MAX_SHARE"""
import math
import sys

WORST_FACTOR = 3


def read_images(path):
    cams = {}
    for line in open(path):
        f = line.split()
        if len(f) == 10 and not line.startswith("#") and f[9].lower().endswith((".png", ".jpg", ".jpeg")):
            q = [float(v) for v in f[1:5]]
            n = math.sqrt(sum(v * v for v in q))
            w, x, y, z = (v / n for v in q)
            R = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                 [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                 [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
            t = [float(v) for v in f[5:8]]
            cams[f[9]] = (R, t)
    return cams


def median(v):
    v = sorted(v)
    return (v[(len(v) - 1) // 2] + v[len(v) // 2]) / 2


def mul(A, B):
    return [[sum(A[i][k] * B[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def tr(A):
    return [[A[j][i] for j in range(3)] for i in range(3)]


def angle(R):
    return math.degrees(math.acos(max(-1.0, min(1.0, (R[0][0] + R[1][1] + R[2][2] - 1) / 2))))


def centre(R, t):
    return [-sum(R[k][i] * t[k] for k in range(3)) for i in range(3)]


def main():
    known, got = read_images(sys.argv[1]), read_images(sys.argv[2])
    max_deg, max_share = float(sys.argv[3]), float(sys.argv[4])
    names = sorted(set(known) & set(got))
    if len(names) < 3:
        sys.exit("compare_cameras: %d cameras in common" % len(names))
    rot_err = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            rk = mul(known[a][0], tr(known[b][0]))
            rg = mul(got[a][0], tr(got[b][0]))
            rot_err.append(angle(mul(tr(rk), rg)))
    # World rotation W with R_got = R_known W^T: W = R_got^T R_known, averaged then re-orthonormalised.
    S = [[0.0] * 3 for _ in range(3)]
    for n in names:
        W = mul(tr(got[n][0]), known[n][0])
        S = [[S[i][j] + W[i][j] for j in range(3)] for i in range(3)]
    for _ in range(50):  # Newton's polar iteration: the nearest rotation
        det = (S[0][0] * (S[1][1] * S[2][2] - S[1][2] * S[2][1]) - S[0][1] * (S[1][0] * S[2][2] - S[1][2] * S[2][0])
               + S[0][2] * (S[1][0] * S[2][1] - S[1][1] * S[2][0]))
        inv_t = [[(S[(j + 1) % 3][(i + 1) % 3] * S[(j + 2) % 3][(i + 2) % 3]
                   - S[(j + 1) % 3][(i + 2) % 3] * S[(j + 2) % 3][(i + 1) % 3]) / det for j in range(3)] for i in range(3)]
        inv_t = tr(inv_t)
        S = [[(S[i][j] + inv_t[i][j]) / 2 for j in range(3)] for i in range(3)]
    ck = [centre(*known[n]) for n in names]
    cg = [centre(*got[n]) for n in names]
    mk = [sum(c[i] for c in ck) / len(ck) for i in range(3)]
    mg = [sum(c[i] for c in cg) / len(cg) for i in range(3)]
    rot = [[sum(S[i][k] * (c[k] - mk[k]) for k in range(3)) for i in range(3)] for c in ck]  # W (C_known - mean)
    dg = [[c[i] - mg[i] for i in range(3)] for c in cg]
    s = sum(sum(a[i] * b[i] for i in range(3)) for a, b in zip(rot, dg)) / sum(sum(a[i] ** 2 for i in range(3)) for a in rot)
    extent = max(math.sqrt(sum((c[i] - mk[i]) ** 2 for i in range(3))) for c in ck)
    c_err = [math.sqrt(sum((b[i] / s - a[i]) ** 2 for i in range(3))) / extent for a, b in zip(rot, dg)]
    print("%d cameras: relative rotation error median %.3f worst %.3f deg; centre error median %.3f worst %.3f %% "
          "of the extent" % (len(names), median(rot_err), max(rot_err), 100 * median(c_err), 100 * max(c_err)))
    ok = (median(rot_err) < max_deg and median(c_err) < max_share
          and max(rot_err) < WORST_FACTOR * max_deg and max(c_err) < WORST_FACTOR * max_share)
    sys.exit(0 if ok else 1)


main()
