#!/bin/sh
# Makes a PDDLStream checkout that runs beside ltamp for bench/planner_hidden.py:
#   sh bench/problems/hidden19/pddlstream_setup.sh SOURCE DEST
# SOURCE: a PDDLStream checkout whose downward/src/translate is caelan/downward's translator
# (e.g. /work/pddlstream-src/.real); DEST: a scratch copy (PDDLStream writes temp/ and
# statistics/ into its working directory; the bench runs it in scratch folders).
# The search binary is the one inside the up-fast-downward wheel. It is newer than the
# translator: its heuristics take eval_modify_costs(h(), cost_type=plusone) instead of
# h(transform=adapt_costs(cost_type=PLUSONE)), and it computes the negated-axiom rules the
# old translator writes (and rejects them in its input), so a filter drops those rules.
set -eu
source=$1
dest=$2
here=$(cd "$(dirname "$0")" && pwd)
binary=$(python -c "import importlib.util, os; spec = importlib.util.find_spec('up_fast_downward'); print(os.path.join(os.path.dirname(spec.origin), 'downward/builds/release/bin/downward'))")
mkdir -p "$dest"
cp -r "$source"/. "$dest"/
rm -rf "$dest/temp" "$dest/statistics" "$dest/visualizations"
bin="$dest/downward/builds/release/bin"
mkdir -p "$bin"
[ -e "$bin/translate" ] || ln -s ../../../src/translate "$bin/translate"
cp "$here/sas_filter.awk" "$bin/sas_filter.awk"
rm -f "$bin/downward"
printf '#!/bin/sh\nawk -f "$(dirname "$0")/sas_filter.awk" | %s "$@"\n' "$binary" > "$bin/downward"
chmod +x "$bin/downward"
for h in ff add hmax blind lmcut cea; do
  sed -i "s/$h(transform=adapt_costs(cost_type=PLUSONE))/eval_modify_costs($h(), cost_type=plusone)/g" \
    "$dest/pddlstream/algorithms/downward.py"
done
sed -i 's/ff(transform=no_transform())/ff()/g; s/goalcount(transform=no_transform())/goalcount()/g' \
  "$dest/pddlstream/algorithms/downward.py"
echo "PDDLStream ready at $dest"
