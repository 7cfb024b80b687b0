"""Writing the bench scripts' tables (imported by their Python parts: PYTHONPATH=bench)."""
import csv
import json


def write_json_and_csv(out, name, rows):
    """Writes rows (dicts) to OUT/NAME.json whole and to OUT/NAME.csv with the scalar columns of
    the first row; prints where."""
    with open(f"{out}/{name}.json", "w") as f:
        json.dump(rows, f, indent=2)
    keys = [k for k in rows[0] if not isinstance(rows[0][k], (list, dict))]
    with open(f"{out}/{name}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    print(f"JSON and CSV: {out}/{name}.json, {out}/{name}.csv")
