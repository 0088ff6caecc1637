#!/usr/bin/env bash
# Make the base image docker/Dockerfile starts FROM (docker.io/library/debian:bookworm-slim)
# available in this machine's local image store, on a machine that reaches Debian's package archive
# but no container registry (CI, our build machines). Run as root; once per machine, about 30 s.
#
#   scripts/container-base-image.sh            # no-op when the image is already there
#   scripts/container-base-image.sh --force    # rebuild it (e.g. to pick up Debian point releases)
#
# It bootstraps a minimal Debian 12 root with debootstrap from the archive this machine's apt
# already uses, trims it the way the official -slim image is trimmed (no docs, man pages or
# locales; apt told not to keep .debs or fetch translations), and imports it under the official
# name so `buildah bud --pull=never` resolves `FROM debian:bookworm-slim` to it. On a machine with
# registry access none of this is needed: `docker build` pulls the real image.
#
# Needs: debootstrap, podman (scripts/install-deps.sh --container-test).
set -euo pipefail

name=docker.io/library/debian:bookworm-slim
force=false
case "${1:-}" in
  "") ;;
  --force) force=true ;;
  *) echo "container-base-image: unknown option \"$1\" (only --force)" >&2; exit 2 ;;
esac

if [[ $(id -u) -ne 0 ]]; then
  echo "container-base-image: run as root (debootstrap needs it)" >&2
  exit 1
fi
for tool in debootstrap podman; do
  command -v "$tool" >/dev/null ||
    { echo "container-base-image: $tool missing; run scripts/install-deps.sh --container-test" >&2; exit 1; }
done

if ! $force && podman image exists "$name" 2>/dev/null; then
  echo "container-base-image: $name is already here"
  exit 0
fi

# The Debian archive (and security archive) this machine's apt uses: deb822 .sources files first,
# then classic one-line sources.list entries. Other repositories (vendor apt repos) are skipped:
# only URIs that serve the bookworm suite qualify.
sources_uris() {
  local suite=$1
  {
    # deb822: a stanza's URIs: and Suites: lines; print the URI of stanzas listing $suite.
    awk -v suite="$suite" '
      /^[[:space:]]*$/ { if (uri != "" && has) print uri; uri = ""; has = 0; next }
      tolower($1) == "uris:" { uri = $2 }
      tolower($1) == "suites:" { for (i = 2; i <= NF; i++) if ($i == suite) has = 1 }
      END { if (uri != "" && has) print uri }' /etc/apt/sources.list.d/*.sources 2>/dev/null || true
    # one-line: deb [options] URI SUITE COMPONENTS...
    grep -hE '^[[:space:]]*deb[[:space:]]' /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null |
      sed -E 's/\[[^]]*\]//' | awk -v suite="$suite" '$3 == suite { print $2 }' || true
  } | head -1
}
mirror=$(sources_uris bookworm)
security=$(sources_uris bookworm-security)
[[ -n "$mirror" ]] || { echo "container-base-image: no Debian bookworm archive in this machine's apt sources" >&2; exit 1; }

root=$(mktemp -d /tmp/bookworm-root.XXXXXX)
log=/tmp/container-base-image.log
trap 'rm -rf "$root"' EXIT

echo "container-base-image: debootstrap bookworm from $mirror (log: $log)"
start=$SECONDS
debootstrap --variant=minbase bookworm "$root" "$mirror" >"$log" 2>&1 ||
  { tail -20 "$log" >&2; echo "container-base-image: debootstrap failed, see $log" >&2; exit 1; }

# What the official image does to be "slim" (debuerreotype's slimify and docker-* apt settings).
cat >"$root/etc/dpkg/dpkg.cfg.d/docker" <<'EOF'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/groff/*
path-exclude /usr/share/info/*
path-exclude /usr/share/lintian/*
path-exclude /usr/share/linda/*
path-exclude /usr/share/locale/*
path-include /usr/share/locale/locale.alias
EOF
find "$root/usr/share/doc" -mindepth 1 -not -name copyright -not -type d -delete
find "$root/usr/share/doc" -mindepth 1 -type d -empty -delete
rm -rf "$root"/usr/share/{man,groff,info,lintian,linda}/*
find "$root/usr/share/locale" -mindepth 1 -maxdepth 1 -not -name locale.alias -exec rm -rf {} +
cat >"$root/etc/apt/apt.conf.d/docker-clean" <<'EOF'
DPkg::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
APT::Update::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
Dir::Cache::pkgcache "";
Dir::Cache::srcpkgcache "";
EOF
echo 'Acquire::Languages "none";' >"$root/etc/apt/apt.conf.d/docker-no-languages"
echo 'Apt::AutoRemove::SuggestsImportant "false";' >"$root/etc/apt/apt.conf.d/docker-autoremove-suggests"

# Sources as the official image has them (updates and security too), from the mirror found above.
rm -f "$root/etc/apt/sources.list"
{
  printf 'Types: deb\nURIs: %s\nSuites: bookworm bookworm-updates\nComponents: main\n' "$mirror"
  printf 'Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg\n'
  if [[ -n "$security" ]]; then
    printf '\nTypes: deb\nURIs: %s\nSuites: bookworm-security\nComponents: main\n' "$security"
    printf 'Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg\n'
  fi
} >"$root/etc/apt/sources.list.d/debian.sources"
rm -rf "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/*.bin "$root"/var/cache/apt/archives/*.deb \
  "$root"/var/log/* "$root"/tmp/* "$root"/root/.cache
: >"$root/etc/resolv.conf"  # the engine provides one at run time
echo debian >"$root/etc/hostname"

tar --numeric-owner -C "$root" -c . |
  podman import --quiet --change 'CMD ["bash"]' --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
    - "$name" >/dev/null
echo "container-base-image: imported $name ($(du -sh "$root" | cut -f1)) in $((SECONDS - start)) s"
