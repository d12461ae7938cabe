#!/bin/sh
# Runs a usb test (or its test listing) under umockdev-wrapper. umockdev's LD_PRELOAD library
# then loads before the AddressSanitizer runtime, which ASan accepts only when told.
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}verify_asan_link_order=0"
exec umockdev-wrapper "$@"
