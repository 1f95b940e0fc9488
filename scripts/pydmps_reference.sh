#!/usr/bin/env bash
# Regenerates crates/dmp/test_data/pydmps_0_2.json, the reference values that
# crates/dmp/tests/pydmps.rs compares our rhythmic DMP with. Needs Python 3 and
# PyPI; installs pydmps 0.2 (the version of Vakulenko et al. 2017) with numpy and
# scipy into .venv-ref/ (gitignored). The tests themselves never run Python.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv-ref
.venv-ref/bin/pip install -q "pydmps==0.2" numpy scipy
.venv-ref/bin/python scripts/pydmps_reference.py > crates/dmp/test_data/pydmps_0_2.json.tmp
mv crates/dmp/test_data/pydmps_0_2.json.tmp crates/dmp/test_data/pydmps_0_2.json
echo "wrote crates/dmp/test_data/pydmps_0_2.json"
