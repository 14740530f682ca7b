#!/usr/bin/python3
"""Rows and summary of scripts/bench_generalisation (one building's files -> TSV rows; all rows -> the report)."""
import re
import sys

GOOD = (0.5, 0.2, 20.0)   # focal %, rotation deg, position mm: the goal with a perfect localiser
FAIR = (0.5, 0.3, 30.0)   # ... with the localiser error of the map issue
WRONG = (5.0, 2.0, 100.0)  # an accepted result this far off is wrong


def row(seed, directory, seconds):
    world = open(directory + "/world.txt").read().splitlines()
    kind = re.search(r": (\w+);", world[0]).group(1)
    log = open(directory + "/calibrate.log").read()
    compare = open(directory + "/compare.md").read()
    for line in world[1:]:
        m = re.match(r"\s+(\S+) (\d+x\d+) fx (\S+) \(HFOV (\S+) deg\) at \S+ \S+ (\S+),", line)
        if not m:
            continue
        name, size, fx, hfov, height = m.groups()
        failed = re.search(r"^%s: FAILED: (.*)$" % name, log, re.M)
        cells = [seed, kind, name, size, hfov, height]
        # The map's coverage of the camera's image lines (calibrate_survey --truth-dir), then the focal sigma (%)
        covered = re.search(r"^truth-coverage %s ([0-9.]+) %%" % name, log, re.M)
        coverage = covered.group(1) if covered else ""
        result = re.search(r"^\| %s \| ([-+0-9.]+) %% \|[^|]*\|[^|]*\| ([0-9.]+) deg \| ([0-9.]+) mm \|"
                           r"[^|]*\|[^|]*\| ([0-9.]+) px / ([0-9.]+) mm / ([0-9.]+) deg" % name, compare, re.M)
        if failed or not result:
            reason = failed.group(1) if failed else "no result (see calibrate.log)"
            # With the truth, calibrate_survey says how far the refused result was: was the refusal needed?
            # (the camera's own lines, such as its survey hint, may come between)
            truth = re.search(r"^%s: FAILED: .*\n(?:%s: .*\n)*  truth of the refused result: focal ([-+0-9.]+) %%, "
                              r"rotation ([0-9.]+) deg, position ([0-9.]+) mm" % (name, name), log, re.M)
            refused = category(*(abs(float(x)) for x in truth.groups())) if truth else ""
            print("\t".join(cells + ["refused", "", "", "", reason, seconds, refused, "", "", coverage, ""]))
            continue
        focal, rotation, position = abs(float(result.group(1))), float(result.group(2)), float(result.group(3))
        sigma_focal = 100.0 * float(result.group(4)) / float(fx)  # % of the true focal length, as the error
        print("\t".join(cells + [category(focal, rotation, position), "%.3f" % focal, "%.3f" % rotation,
                                 "%.1f" % position, "", seconds, "", result.group(5), result.group(6),
                                 coverage, "%.4f" % sigma_focal]))


def category(focal, rotation, position):
    errors = (focal, rotation, position)
    return ("WRONG" if any(e > w for e, w in zip(errors, WRONG)) else
            "good" if all(e <= g for e, g in zip(errors, GOOD)) else
            "fair" if all(e <= g for e, g in zip(errors, FAIR)) else "off")


def percentile(values, p):
    values = sorted(values)
    if not values:
        return float("nan")
    k = (len(values) - 1) * p / 100.0
    lo = int(k)
    hi = min(lo + 1, len(values) - 1)
    return values[lo] + (values[hi] - values[lo]) * (k - lo)


def reason_class(reason):
    reason = re.sub(r"\(.*?\)", "(...)", reason)
    reason = re.sub(r"[-+]?\d+(\.\d+)?", "N", reason)
    return reason.split(";")[0].strip()


def summary(path):
    rows = [line.rstrip("\n").split("\t") for line in open(path) if line.strip()]
    print("\n| seed | kind | camera | size | HFOV | height | coverage | result | focal error | rotation | position | "
          "reason |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        errors = ("%s %% | %s deg | %s mm" % (r[7], r[8], r[9])) if r[7] else " | | "
        if r[6] == "refused" and len(r) > 12 and r[12]:
            r[10] += " (the refused result was %s)" % r[12]
        coverage = ("%s %%" % r[15]) if len(r) > 15 and r[15] else ""
        print("| %s | %s | %s | %s | %s deg | %s m | %s | %s | %s | %s |" % (r[0], r[1], r[2], r[3], r[4], r[5],
                                                                              coverage, r[6], errors, r[10]))
    n = len(rows)
    count = {s: sum(1 for r in rows if r[6] == s) for s in ("good", "fair", "off", "WRONG", "refused")}
    buildings = len(set(r[0] for r in rows))
    print("\n%d cameras in %d buildings: %d accepted, %d refused" % (n, buildings, n - count["refused"],
                                                                     count["refused"]))
    pct = lambda k: 100.0 * k / n if n else 0.0
    print("  within 0.5 %% / 0.2 deg / 2 cm (goal >= 90 %%):  %d (%.0f %%)" % (count["good"], pct(count["good"])))
    print("  within 0.5 %% / 0.3 deg / 3 cm (goal >= 80 %%):  %d (%.0f %%)" % (count["good"] + count["fair"],
                                                                        pct(count["good"] + count["fair"])))
    print("  accepted, less accurate but not wrong:         %d" % count["off"])
    print("  accepted WRONG (> 5 %% focal, 2 deg or 10 cm):  %d (goal 0)" % count["WRONG"])
    coverages = [float(r[15]) for r in rows if len(r) > 15 and r[15]]
    if coverages:
        print("  map coverage of the cameras' image lines (truth-coverage; median / min / max): %.1f / %.1f / %.1f %%"
              % (percentile(coverages, 50), min(coverages), max(coverages)))
    reasons = {}
    for r in rows:
        if r[6] == "refused":
            reasons[reason_class(r[10])] = reasons.get(reason_class(r[10]), 0) + 1
    judged = [r for r in rows if r[6] == "refused" and len(r) > 12 and r[12]]
    if judged:
        print("  refused results that were (with the truth): %s" % ", ".join(
            "%s %d" % (c, sum(1 for r in judged if r[12] == c)) for c in ("good", "fair", "off", "WRONG")))
    print("  refusals by reason:")
    for reason, k in sorted(reasons.items(), key=lambda x: -x[1]):
        print("    %3d  %s" % (k, reason))
    # The survey hint's clause for a region the Xtion has nowhere in view within its depth's reach (survey_guidance.h).
    mount = sum(1 for r in rows if r[6] == "refused" and "within its depth's reach" in r[10])
    if mount:
        print("  refusals whose hint says a region is out of the Xtion's reach (pitch or mount it differently): %d"
              % mount)
    accepted = [r for r in rows if r[7]]
    if accepted:
        print("  errors of the accepted results (median / 90th percentile / max):")
        for name, column, unit in (("focal", 7, "%"), ("rotation", 8, "deg"), ("position", 9, "mm")):
            v = [float(r[column]) for r in accepted]
            print("    %-9s %8.3f / %8.3f / %8.3f %s" % (name, percentile(v, 50), percentile(v, 90), max(v), unit))
    # Honesty of the reported uncertainty: an accepted result's error within twice its one-sigma (position: the
    # square root of the covariance's trace, so 2 sigma covers a 3D error more than 95 % of the time).
    sigmas = [r for r in accepted if len(r) > 14 and r[13]]
    if sigmas:
        covered = lambda rows, err, sig: sum(1 for r in rows if float(r[err]) <= 2.0 * float(r[sig]))
        line = ("  two-sigma coverage of the accepted results (goal >= 90 %%): position %d of %d, rotation %d of %d" %
                (covered(sigmas, 9, 13), len(sigmas), covered(sigmas, 8, 14), len(sigmas)))
        focal = [r for r in sigmas if len(r) > 16 and r[16]]  # rows of older runs have no focal sigma
        if focal:
            line += ", focal %d of %d" % (covered(focal, 7, 16), len(focal))
        print(line)
    by_kind = {}
    for r in rows:
        k = by_kind.setdefault(r[1], [0, 0, 0])
        k[0] += 1
        k[1] += r[6] in ("good", "fair")
        k[2] += r[6] == "WRONG"
    print("  per kind (cameras / within 0.5 % 0.3 deg 3 cm / wrong): " +
          ", ".join("%s %d/%d/%d" % (k, v[0], v[1], v[2]) for k, v in sorted(by_kind.items())))


def passes(first_path, second_path, drives_path, route_s):
    """Each camera's result in the first survey and after following the hints, and the surveys' durations."""
    read = lambda path: {(r[0], r[2]): r for r in (line.rstrip("\n").split("\t") for line in open(path)
                                                    if line.strip())}
    first, second = read(first_path), read(second_path)
    changes = {}
    for key, r in first.items():
        after = second[key][6] if key in second else "missing"
        changes[(r[6], after)] = changes.get((r[6], after), 0) + 1
    print("\ncamera results, first survey -> after following the hints: " + ", ".join(
        "%s -> %s %d" % (a, b, k) for (a, b), k in sorted(changes.items())))
    newly_wrong = [k for k, r in second.items() if r[6] == "WRONG" and first.get(k, [""] * 7)[6] != "WRONG"]
    if newly_wrong:
        print("  accepted WRONG after following the hints: " + ", ".join("seed %s %s" % k for k in newly_wrong))
    # What an operator ends with who keeps each camera the first survey calibrated (accepted, whatever its error)
    # and calibrates only the refused ones from the second survey.
    kept = {key: (r if r[6] != "refused" or key not in second else second[key]) for key, r in first.items()}
    count = lambda *c: sum(1 for r in kept.values() if r[6] in c)
    print("first survey's accepted cameras kept, the refused ones from the second survey: %d of %d good, %d within "
          "0.5 %% / 0.3 deg / 3 cm, %d off, %d WRONG, %d refused" % (
              count("good"), len(kept), count("good", "fair"), count("off"), count("WRONG"), count("refused")))
    drives = [line.split() for line in open(drives_path) if line.strip()]
    if drives:
        extra = [float(d[4]) for d in drives]
        tilt = lambda d: (", Xtion at %s deg" % d[5]) if len(d) > 5 else ""
        print("surveys extended: %d buildings, the %s s route + visits (extra drive median / max: %.0f / %.0f s; "
              "simulated): %s" % (len(drives), route_s, percentile(extra, 50), max(extra), ", ".join(
                  "seed %s %s s (%s visits%s)" % (d[0], d[3], d[2], tilt(d)) for d in drives)))


if __name__ == "__main__":
    if sys.argv[1] == "row":
        row(*sys.argv[2:5])
    elif sys.argv[1] == "passes":
        passes(*sys.argv[2:6])
    else:
        summary(sys.argv[2])
