#!/usr/bin/env bash
# Validates the ESI of every built-in profile against the ETG EtherCATInfo schema with xmllint.
#
# The schema files may not be committed (ETG copyright, see ../shared/reference/esi-sii.md §1),
# so this is a local check, not part of CI: pass a folder holding EtherCATInfo.xsd and
# EtherCATBase.xsd, e.g. the ETG download, a TwinCAT Config/Io/EtherCAT folder, or
# synapticon/siitool@b663c24:examples/ (schema 1.17, EtherCATInfo.xsd sha256 e3d36733…).
#
#   od-gen/scripts/esi-schema-check.sh /path/to/xsd
#
# Needs xmllint (Debian: libxml2-utils). Exit status 1 if any ESI fails.
set -euo pipefail
xsd_dir=${1:?usage: esi-schema-check.sh <folder with EtherCATInfo.xsd>}
[ -f "$xsd_dir/EtherCATInfo.xsd" ] || { echo "no EtherCATInfo.xsd in $xsd_dir" >&2; exit 2; }
command -v xmllint >/dev/null || { echo "xmllint not found (apt-get install libxml2-utils)" >&2; exit 2; }
cd "$(dirname "$0")/../.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
status=0
for profile in $(cargo run -q -p od-gen -- list); do
    cargo run -q -p od-gen -- esi "$profile" -o "$out/$profile.xml"
    if xmllint --noout --schema "$xsd_dir/EtherCATInfo.xsd" "$out/$profile.xml" 2>"$out/$profile.log"; then
        echo "valid: $profile"
    else
        echo "INVALID: $profile"; cat "$out/$profile.log"; status=1
    fi
done
exit $status
