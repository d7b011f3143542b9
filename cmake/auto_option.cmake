# numen_auto_option(NAME FOUND DOC): an optional part of the build that is built where what it
# needs is installed. The cache entry NAME is AUTO (the default), ON or OFF:
#  - AUTO follows FOUND at every configure, so a build directory configured before the part's
#    packages were installed (the README's run command installs only what `numen` needs) builds
#    the part at its next configure, once they are;
#  - ON requires them: the caller makes their absence a configure error (NAME_REQUIRED is ON);
#  - OFF leaves the part out.
# The decision is the normal variable NAME (ON or OFF) in the caller's scope, which shadows the
# cache entry there and in the directories added below it.
function(numen_auto_option name found doc)
  set(${name} AUTO CACHE STRING "${doc} (AUTO: where its packages are found; ON: required; OFF)")
  set_property(CACHE ${name} PROPERTY STRINGS AUTO ON OFF)
  set(_value "$CACHE{${name}}")
  set(_required OFF)
  if(_value STREQUAL "AUTO")
    if(found)
      set(_on ON)
    else()
      set(_on OFF)
    endif()
  elseif(_value)
    set(_on ON)
    set(_required ON)
  else()
    set(_on OFF)
  endif()
  set(${name} ${_on} PARENT_SCOPE)
  set(${name}_REQUIRED ${_required} PARENT_SCOPE)
endfunction()
