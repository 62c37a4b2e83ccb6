# Used by pddlstream_setup.sh. Drops axiom rules whose old value is not the variable's initial (default) value: the
# negated-axiom rules the old caelan/downward translator writes and that newer Fast
# Downward search binaries compute themselves (and reject in the input).
BEGIN { section = ""; nvars = 0 }
{
  lines[NR] = $0
}
END {
  n = NR; i = 1; out = ""
  while (i <= n) {
    l = lines[i]
    if (l == "begin_state") {
      print l; i++; v = 0
      while (lines[i] != "end_state") { init[v] = lines[i]; v++; print lines[i]; i++ }
      print lines[i]; i++; continue
    }
    if (l ~ /^[0-9]+$/ && lines[i+1] == "begin_rule") {
      # number of rules: count the kept ones first
      total = l + 0; j = i + 1; kept = 0; buf = ""
      for (r = 0; r < total; r++) {
        nc = lines[j+1] + 0
        split(lines[j+2+nc], eff, " ")
        block = ""
        for (k = j; k <= j + 3 + nc; k++) block = block lines[k] "\n"
        if (eff[2] == init[eff[1]]) { kept++; buf = buf block }
        j = j + 4 + nc
      }
      printf "%d\n%s", kept, buf
      i = j; continue
    }
    print l; i++
  }
}
