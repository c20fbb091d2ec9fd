"""Joins the peers' and our results (run_peers.sh's TSV format) into one markdown table."""
import csv
import sys


def read(path):
    try:
        with open(path, newline="") as handle:
            return list(csv.DictReader(handle, delimiter="\t"))
    except FileNotFoundError:
        return []


def main():
    peers, ours = read(sys.argv[1]), read(sys.argv[2])
    codes = ["ours", "liggghts", "lammps", "yade"]
    by_scenario = {}
    order = []
    for row in ours + peers:
        key = row["scenario"]
        if key not in by_scenario:
            by_scenario[key] = {}
            order.append(key)
        by_scenario[key][row["code"]] = row
    print("| scenario | N | bonds | " + " | ".join(codes) + " | ours / best peer |")
    print("|---|---:|---:|" + "---:|" * len(codes) + "---:|")
    for key in order:
        rows = by_scenario[key]
        first = next(iter(rows.values()))
        cells = []
        for code in codes:
            row = rows.get(code)
            cells.append(f"{float(row['particle_steps_per_s']):.2e}" if row else "-")
        peer_best = max((float(r["particle_steps_per_s"]) for c, r in rows.items() if c != "ours"),
                        default=None)
        ratio = (f"{float(rows['ours']['particle_steps_per_s']) / peer_best:.2f}"
                 if peer_best and "ours" in rows else "-")
        print(f"| {key} | {first['N']} | {first['bonds']} | " + " | ".join(cells) + f" | {ratio} |")
    print()
    print("particle-steps per second = N x timed steps / wall seconds of the timed segment "
          "(settling excluded). Scenario names: _npK = K cores (MPI ranks for the peers, "
          "threads for ours).")


if __name__ == "__main__":
    main()
