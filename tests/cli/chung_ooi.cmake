# Hertz-Mindlin tangential law from the command line (issue 21; docs/chung_ooi.md): the kernel runs, and
# every bad key is refused with exit code 2 before anything starts.
file(WRITE ${POLYDEM_CLI_WORK}/relax_mindlin.toml "[particles]
count = 100
distribution = \"uniform-volume\"
omega = 3
rmin = 1e-3
packing_fraction = 0.3
density = 2800.0
[box]
boundaries = [\"periodic\", \"periodic\", \"wall\"]
[contact]
law = \"hertz\"
stiffness = 3.3e10
restitution = 0.9
friction = 0.35
tangential = \"hertz-mindlin\"
poisson_ratio = 0.2
[run]
steps = 200
gravity = [0.0, 0.0, -9.81]
progress_interval = 0.0
")
set(_M relax relax_mindlin.toml -q)
polydem_cli_test(NAME chung_ooi_relax_mindlin COMMAND ${_M}
                 PASS "kernel hertz\\+hertz-mindlin \\[walls gravity\\]" LABELS verification)
polydem_cli_test(NAME chung_ooi_relax_mindlin_shear_modulus COMMAND ${_M} --set contact.shear_modulus=1e10
                 --set contact.poisson_ratio=0.2
                 EXIT 2 PASS "needs exactly one of contact.shear_modulus" FAIL "relax report" LABELS verification)
polydem_cli_test(NAME chung_ooi_relax_mindlin_linear COMMAND ${_M} --set contact.law=linear
                 EXIT 2 PASS "contact.tangential = \"hertz-mindlin\" needs contact.law = \"hertz\"" FAIL "relax report"
                 LABELS verification)
polydem_cli_test(NAME chung_ooi_relax_mindlin_bad_poisson COMMAND ${_M} --set contact.poisson_ratio=0.7
                 EXIT 2 PASS "contact.poisson_ratio must be in \\[0, 0.5\\]" FAIL "relax report" LABELS verification)
polydem_cli_test(NAME chung_ooi_relax_mindlin_bad_law_name COMMAND ${_M} --set contact.tangential=mindlin
                 EXIT 2 PASS "contact.tangential" FAIL "relax report" LABELS verification)
