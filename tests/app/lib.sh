# Shared by the CLI shell tests: pass/fail counters and an output check.
pass=0; fail=0
ok()   { pass=$((pass+1)); }
bad()  { fail=$((fail+1)); echo "FAIL: $*"; }
expect_contains() { # name, haystack, needle
  if grep -qF -- "$3" <<<"$2"; then ok; else bad "$1: output lacks '$3'"; echo "$2" | head -20; fi
}
