#!/usr/bin/env bash
# gaussvid itself: usage, help, version, unknown commands, and the OpenMP wait policy it
# chooses when the user has not (threads spin briefly, then sleep; see src/cli/runtime_env.c).
. "$(dirname "$0")/lib/harness.sh"
cli_setup main "$1"

expect 2 "no command" -- "$G"
grep -q "usage: gaussvid COMMAND" "$T/err"; check_rc "usage on stderr" $?
expect 0 "help" -- "$G" help
has "restore"
expect 0 "version" -- "$G" version
has "gaussvid 0.1.0"
expect 2 "unknown command" -- "$G" nope
one_line "unknown command 'nope'"

# libgomp prints its settings with OMP_DISPLAY_ENV; the last print is the program's own run.
expect 0 "wait policy unset" -- env -u OMP_WAIT_POLICY -u GOMP_SPINCOUNT OMP_DISPLAY_ENV=verbose "$G" version
# about 30 us of rounds of the pause instruction, as timed at start: 100 to 30000 rounds,
# never libgomp's own 300000 (passive is 0)
rounds=$(grep "GOMP_SPINCOUNT" "$T/err" | tail -n 1 | tr -dc 0-9)
[ -n "$rounds" ] && [ "$rounds" -ge 100 ] && [ "$rounds" -le 30000 ]; check_rc "a short spin when unset ($rounds rounds)" $?
grep "OMP_WAIT_POLICY" "$T/err" | tail -n 1 | grep -q PASSIVE; check_rc "not the active policy when unset" $?
expect 0 "spin count chosen" -- env -u OMP_WAIT_POLICY GOMP_SPINCOUNT=77 OMP_DISPLAY_ENV=verbose "$G" version
grep "GOMP_SPINCOUNT" "$T/err" | tail -n 1 | grep -q "'77'"; check_rc "the user's spin count is kept" $?
expect 0 "wait policy chosen" -- env OMP_WAIT_POLICY=active OMP_DISPLAY_ENV=true "$G" version
grep "OMP_WAIT_POLICY" "$T/err" | tail -n 1 | grep -q ACTIVE; check_rc "the user's choice is kept" $?

cli_finish
