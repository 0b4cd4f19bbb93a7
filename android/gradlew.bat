@rem Gradle start-up script of the fpbp Android project (Windows).
@rem
@rem - gradle\wrapper\gradle-wrapper.jar present: runs it, as Gradle's own
@rem   gradlew.bat does.
@rem - jar absent (the repository does not commit it; "gradlew wrapper" or
@rem   "gradle wrapper" writes it): gradle\wrapper\gradlew-bootstrap.ps1
@rem   (PowerShell) downloads distributionUrl, checks distributionSha256Sum and
@rem   unpacks it where the wrapper jar would; this script then runs its
@rem   bin\gradle.bat.
@rem
@rem Environment: JAVA_HOME (else java on PATH), JAVA_OPTS, GRADLE_OPTS,
@rem GRADLE_USER_HOME (default %USERPROFILE%\.gradle).

@if "%DEBUG%"=="" @echo off
setlocal

set DIRNAME=%~dp0
if "%DIRNAME%"=="" set DIRNAME=.\
set APP_BASE_NAME=%~n0
for %%i in ("%DIRNAME%.") do set APP_HOME=%%~fi

set WRAPPER_JAR=%APP_HOME%\gradle\wrapper\gradle-wrapper.jar
if exist "%WRAPPER_JAR%" goto withJar

@rem Without the jar: bootstrap the distribution, then run its gradle.bat.
set GRADLE_DIST_HOME=
for /f "usebackq delims=" %%g in (`powershell -NoProfile -NonInteractive -ExecutionPolicy Bypass -File "%APP_HOME%\gradle\wrapper\gradlew-bootstrap.ps1" -ProjectDir "%APP_HOME%"`) do set "GRADLE_DIST_HOME=%%g"
if not defined GRADLE_DIST_HOME goto bootstrapFailed
if not exist "%GRADLE_DIST_HOME%\bin\gradle.bat" goto bootstrapFailed
call "%GRADLE_DIST_HOME%\bin\gradle.bat" %*
exit /b %ERRORLEVEL%

:bootstrapFailed
echo. 1>&2
echo ERROR: could not install the Gradle distribution of gradle\wrapper\gradle-wrapper.properties 1>&2
echo (see the messages above; needs Windows PowerShell 5.1 or later). 1>&2
exit /b 1

:withJar
if defined JAVA_HOME goto findJavaFromJavaHome

set JAVA_EXE=java.exe
%JAVA_EXE% -version >NUL 2>&1
if %ERRORLEVEL% equ 0 goto execute

echo. 1>&2
echo ERROR: JAVA_HOME is not set and no 'java' command could be found in your PATH. 1>&2
echo Please set the JAVA_HOME variable in your environment to match the 1>&2
echo location of your Java installation. 1>&2
exit /b 1

:findJavaFromJavaHome
set JAVA_HOME=%JAVA_HOME:"=%
set JAVA_EXE=%JAVA_HOME%\bin\java.exe
if exist "%JAVA_EXE%" goto execute

echo. 1>&2
echo ERROR: JAVA_HOME is set to an invalid directory: %JAVA_HOME% 1>&2
echo Please set the JAVA_HOME variable in your environment to match the 1>&2
echo location of your Java installation. 1>&2
exit /b 1

:execute
"%JAVA_EXE%" -Xmx64m -Xms64m %JAVA_OPTS% %GRADLE_OPTS% "-Dorg.gradle.appname=%APP_BASE_NAME%" -classpath "%WRAPPER_JAR%" org.gradle.wrapper.GradleWrapperMain %*
exit /b %ERRORLEVEL%
