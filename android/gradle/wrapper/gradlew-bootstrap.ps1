# Used by gradlew.bat when gradle/wrapper/gradle-wrapper.jar is absent (the
# repository does not commit it): does the wrapper jar's work. Reads
# gradle-wrapper.properties, downloads distributionUrl (Invoke-WebRequest;
# file: URLs are copied), checks distributionSha256Sum when set, unpacks the
# zip into the folder the wrapper jar uses
# (%GRADLE_USER_HOME%\wrapper\dists\<name>\<base 36 MD5 of the URL>, with the
# jar's "<zip>.ok" marker, so the jar and Android Studio reuse the download)
# and prints the distribution's home folder as its last line of output.
# Messages go to stderr. Windows PowerShell 5.1 or PowerShell 7.
param([Parameter(Mandatory = $true)][string]$ProjectDir)

$ErrorActionPreference = 'Stop'
$ProgressPreference = 'SilentlyContinue' # the progress bar slows Invoke-WebRequest down a lot

function Fail([string]$message) {
    [Console]::Error.WriteLine("ERROR: $message")
    exit 1
}

function Say([string]$message) {
    [Console]::Error.WriteLine($message)
}

$propsFile = Join-Path $ProjectDir 'gradle\wrapper\gradle-wrapper.properties'
if (-not (Test-Path -LiteralPath $propsFile)) { Fail "$propsFile not found" }

# key=value lines; the properties escapes (\: \= \\) undone; the last one wins.
$props = @{}
foreach ($line in Get-Content -LiteralPath $propsFile) {
    if ($line -match '^\s*([^#!=:\s]+)\s*[=:]\s*(.*)$') {
        $props[$Matches[1]] = ($Matches[2].TrimEnd() -replace '\\(.)', '$1')
    }
}

$url = $props['distributionUrl']
if (-not $url) { Fail "no distributionUrl in $propsFile" }

$userHome = $env:GRADLE_USER_HOME
if (-not $userHome) { $userHome = Join-Path $env:USERPROFILE '.gradle' }

function BaseDir([string]$key) {
    switch ($props[$key]) {
        'PROJECT' { return $ProjectDir }
        { $_ -eq $null -or $_ -eq '' -or $_ -eq 'GRADLE_USER_HOME' } { return $userHome }
        default { Fail "unknown $key '$($props[$key])' in $propsFile (GRADLE_USER_HOME or PROJECT)" }
    }
}

function OrDefault([string]$value, [string]$default) {
    if ($value) { return $value } else { return $default }
}

# The wrapper jar's folder name: BigInteger(1, md5(url)).toString(36), by long
# division of the 16 MD5 bytes (no big-number type needed).
function Base36Md5([string]$text) {
    $md5 = [System.Security.Cryptography.MD5]::Create()
    [int[]]$digits = $md5.ComputeHash([System.Text.Encoding]::UTF8.GetBytes($text))
    $alphabet = '0123456789abcdefghijklmnopqrstuvwxyz'
    $out = ''
    while (($digits | Where-Object { $_ -ne 0 }).Count -gt 0) {
        $rem = 0
        for ($i = 0; $i -lt $digits.Length; $i++) {
            $acc = $rem * 256 + $digits[$i]
            $digits[$i] = [math]::Floor($acc / 36)
            $rem = $acc % 36
        }
        $out = [string]$alphabet[$rem] + $out
    }
    if ($out -eq '') { $out = '0' }
    return $out
}

$zipName = ($url -split '/')[-1] -replace '\?.*$', ''
$distName = $zipName -replace '\.zip$', ''
$safeUrl = $url -replace '^([A-Za-z][A-Za-z0-9+.-]*://)[^/@]*@', '$1'
$hash = Base36Md5 $safeUrl
$distDir = Join-Path (Join-Path (Join-Path (BaseDir 'distributionBase') (OrDefault $props['distributionPath'] 'wrapper/dists')) $distName) $hash
$zipDir = Join-Path (Join-Path (Join-Path (BaseDir 'zipStoreBase') (OrDefault $props['zipStorePath'] 'wrapper/dists')) $distName) $hash
$zipFile = Join-Path $zipDir $zipName
$marker = "$zipFile.ok"

function GradleHome {
    if (-not (Test-Path -LiteralPath $distDir)) { return $null }
    $homes = @(Get-ChildItem -LiteralPath $distDir -Directory | Where-Object { Test-Path (Join-Path $_.FullName 'bin\gradle.bat') })
    if ($homes.Count -gt 1) { Fail "more than one distribution in ${distDir}: delete the folder and run again" }
    if ($homes.Count -eq 1) { return $homes[0].FullName }
    return $null
}

$gradleHome = $null
if (Test-Path -LiteralPath $marker) { $gradleHome = GradleHome }
if (-not $gradleHome) {
    New-Item -ItemType Directory -Force -Path $distDir, $zipDir | Out-Null
    $part = "$zipFile.part.$PID"
    $unpack = "$distDir.unzip.$PID"
    try {
        Say "Downloading $url"
        if ($url -match '^file:') {
            Copy-Item -LiteralPath ([System.Uri]$url).LocalPath -Destination $part
        } else {
            # TLS 1.2 for Windows PowerShell 5.1. No -TimeoutSec: PowerShell 7
            # applies it to the whole download, not to the connection.
            [Net.ServicePointManager]::SecurityProtocol = [Net.ServicePointManager]::SecurityProtocol -bor [Net.SecurityProtocolType]::Tls12
            Invoke-WebRequest -Uri $url -OutFile $part -UseBasicParsing
        }
        $expected = $props['distributionSha256Sum']
        if ($expected) {
            $got = (Get-FileHash -LiteralPath $part -Algorithm SHA256).Hash.ToLowerInvariant()
            if ($got -ne $expected.ToLowerInvariant()) {
                Fail ("Verification of Gradle distribution failed!`n" +
                    "Your Gradle distribution may have been tampered with.`n" +
                    "Confirm that the 'distributionSha256Sum' property in your gradle-wrapper.properties file is correct and you are downloading the wrapper from a trusted source.`n" +
                    " Distribution Url: $url`nDownload Checksum: $got`nExpected checksum: $expected")
            }
        } else {
            Say "NOTE: no distributionSha256Sum in ${propsFile}: the download is not verified"
        }
        Move-Item -Force -LiteralPath $part -Destination $zipFile
        Say "Unzipping $zipFile to $distDir"
        if (Test-Path -LiteralPath $unpack) { Remove-Item -Recurse -Force -LiteralPath $unpack }
        Expand-Archive -LiteralPath $zipFile -DestinationPath $unpack -Force
        foreach ($dir in Get-ChildItem -LiteralPath $unpack -Directory) {
            $target = Join-Path $distDir $dir.Name
            if (Test-Path -LiteralPath $target) { Remove-Item -Recurse -Force -LiteralPath $target }
            Move-Item -LiteralPath $dir.FullName -Destination $target
        }
    } finally {
        if (Test-Path -LiteralPath $part) { Remove-Item -Force -LiteralPath $part }
        if (Test-Path -LiteralPath $unpack) { Remove-Item -Recurse -Force -LiteralPath $unpack }
    }
    $gradleHome = GradleHome
    if (-not $gradleHome) { Fail "$zipFile holds no <dir>\bin\gradle.bat" }
    New-Item -ItemType File -Force -Path $marker | Out-Null
}

Write-Output $gradleHome
